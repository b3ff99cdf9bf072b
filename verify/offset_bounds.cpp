// Spawn offsets, proved: the derivations (offset_bounds.h; docs/spec/offsets.md).
//
// The model (Higham, "Accuracy and Stability of Numerical Algorithms", §2.2; pbrt-v4 §6.8): each
// +, −, ×, / of the variant's precision rounds once, fl(x ∘ y) = (x ∘ y)(1 + δ), |δ| ≤ u (2^-53
// double, 2^-24 float), while no product underflows. A float variant computes on the primitive and
// ray rounded to float and is judged on them, as everywhere in rayproof (verify/compare.cpp).
//
// Step 1, a running error bound. Every quantity x of a formula is carried as (mag, err): |x| ≤ mag
// for its exact value (the same formula in real arithmetic over the same inputs) and |x̃ − x| ≤ err
// for the value the code computes. Inputs are exact (err 0). For a computed ã ± b̃ the magnitude is
// at most mag_a + mag_b + err_a + err_b, so one rounding adds u times that; for ã·b̃,
// |ãb̃ − ab| ≤ mag_a·err_b + mag_b·err_a + err_a·err_b before its rounding, which adds u·|ãb̃|.
// Every bound is evaluated in double rounded upward (each result moved one double up), so the
// numbers below are upper bounds of the real ones. The bounds are homogeneous of degree one in
// each input that enters a formula linearly (a direction, an origin offset): evaluating them at the
// largest magnitudes bounds every smaller input, and t·bound(d) = bound(t·d).
// Where a value is computed at its own size (not scaled afterwards), a rounding is bounded finer:
// |fl(y) − y| ≤ ½ulp = u·2^⌊log2 |y|⌋ ≤ u·2^⌊log2 mag⌋ (half_ulp_at_most), up to 2× below u·mag.
// That is not homogeneous (2^⌊·⌋ does not scale) nor convex in the inputs, so it serves the
// hit side's N (Möller–Trumbore's s = o − v0 and its products; the plane's off − n·o; the
// watertight test's sheared vertices and edge functions) and the point's own rounding, never D
// (scaled by t̃), the corners' sums, nor the re-hit side's growth in the reach.
//
// Step 2, the hit point off the surface, a posteriori. Formulas that compute t = N/D (Möller–
// Trumbore: N = e2·(s × e1), D = e1·(d × e2) with s = o − v0, and N/D the exact t on the
// triangle's plane, N = n·s, D = −n·d for n = e1 × e2; the plane: N = off − n·o, D = n·d) round
// the quotient k times: t̃ = (Ñ/D̃)(1 + θ), |θ| ≤ γ(k). Then, exactly,
//     N − t̃·D = N − t̃(D̃ − δD) = N − Ñ(1 + θ) + t̃·δD = −δN − θ·Ñ + t̃·δD,
// and Ñ = t̃·D̃/(1 + θ), so with g = γ(k)/(1 − γ(k)):
//     |N − t̃·D| ≤ err_N + |t̃|·(err_D·(1 + g) + g·mag_D).                       (1)
// No division by a small D: (1) holds for grazing rays too. The point the code computes,
// p̃_i = fl(o_i + fl(t̃·d_i)) = o_i + t̃·d_i + r_i with |r_i| ≤ u·2^⌊log2 W_i⌋ + u·2^⌊log2 P_i⌋
// (half an ulp each: a sum that rounds up to a power of two errs by half the finer spacing),
// lies off the plane by n̂·(p̃ − v0) = ±(N − t̃·D)/|n| + n̂·r, hence
//     |n̂·(p̃ − v0)| ≤ (1)/|n| + Σ_i |n̂_i|·(u·2^⌊log2 W_i⌋ + u·2^⌊log2 P_i⌋),          (2)
// with W_i ≥ |t̃·d_i| (the travel from an origin of the scene's box to a point of the domain) and
// P_i ≥ |p̃_i|. |t̃|·err_D is err_D evaluated at the travel W (homogeneity).
//
// Step 3, the re-intersection side. A new ray leaves an origin o′ that lies δ > 0 off the plane
// on the side σ it leaves to (σ·N = δ|n| for Möller–Trumbore, σ·N = −δ|n| for the plane), in a
// direction into that side (σ·D ≤ 0, respectively ≥ 0). A reported hit needs t̃ > 0, and then the
// two terms of N − t̃·D have the same sign, |N − t̃·D| = δ|n| + t̃|D|. With (1), using
// |D̃| ≤ |D| + err_D and g < 1 to drop the t̃|D| that remains on the left,
//     δ·|n| ≤ err_N(o′) + (1 + g)·err_D(W′),                                        (3)
// so no hit is reported once δ exceeds (3)/|n|: err_N at the spawned origins (near the primitive),
// err_D at the travel W′ of a re-hit inside the domain. Both are linear in how far the origins
// reach beyond the primitive's box: rehit_base + rehit_per_reach·reach.
//
// Boxes (slab, robust-slab): the hit face's coordinate. t̃ = fl(fl(plane − o)/d) (slab) or
// fl(fl(plane − o)·fl(1/d)) (robust), so fl(t̃·d_i) = (plane − o_i)(1 + θ), |θ| ≤ γ(3) (slab),
// γ(4) (robust entry) or K̃(1 + γ(5)) − 1 (robust exit, widened by K̃ = fl(1 + 2γ(3))), and
// |p̃_i − plane| ≤ |θ|·W_i + u·P_i/(1 − u). A ray from an origin strictly beyond the face's plane
// (exactly) going away from it, or along it, meets that axis' slab only at t < 0 or never: the
// signs of plane − o, 1/d and their product are exact in floating point, ±0 directions give ±∞
// of the right sign, and widening by K̃ keeps a sign. Any δ > 0 suffices: the re-hit bound is 0.
//
// Spheres (textbook, stable, stable-fma), with f(t) = a t² − 2βt + c = |o + t·d − m|² − R²
// (β = −d·(o − m)): the point p = o + t̃·d lies off the sphere by h = |f(t̃)|/(|p − m| + R) ≤
// |f(t̃)|/R = h₁, and since |p − m| ≥ R − h ≥ R − h₁, by h ≤ |f(t̃)|/(2R − h₁) where h₁ < 2R.
// The code computes ã, β̃, C̃ (errors E_a, E_β, E_C against a, β, c) and D̃, the discriminant in
// β² − ac units (disc/4), with δ_D = D̃ − (β̃² − ãC̃), |δ_D| ≤ κ(β̃² + ã|C̃|), κ = γ(2) (b² − 4ac
// in three roundings; Kahan's FMA form within γ(3)). Let Ĉ = (β̃² − D̃)/ã: then D̃ = β̃² − ãĈ
// exactly, and the roots T1 = q̂/ã, T2 = Ĉ/q̂ of G(t) = ãt² − 2β̃t + Ĉ (q̂ = β̃ ± √D̃, the larger
// magnitude, |T2| ≤ |T1|) are what the code computes up to its last roundings. So
//     |f(t̃)| ≤ |f − G|(t̃) + |G(t̃)|,  |f − G|(t̃) ≤ E_a·t̃² + 2E_β|t̃| + E_C + |δ_D|/ã,     (4)
// and G(t̃) = ã(t̃ − T)(t̃ − T′) for t̃ near its root T:
//   stable q/a: t̃ = T1(1 + η), |η| ≤ γ(3): |G| ≤ γ(3)/(1 − γ(3))·|t̃|·(ã|t̃| + |β̃| + √D̃), or,
//     as G(t̃) = ãηT1(T1 − T2 + ηT1) with |T1 − T2| = 2√D̃/ã and ã|T1| = |β̃| + √D̃,
//     |G| ≤ γ(3)/(1 − γ(3))·|t̃|·(2√D̃ + γ(3)(|β̃| + √D̃)), where D̃ ≤ |d|²R² + its errors;
//   stable c/q: t̃ = (C̃/q̂)(1 + η) = T2(1 + η) + (δ_D/ã)(1 + η)/q̂; with q̂² ≥ β̃², q̂² ≥ ã|Ĉ| (D̃ ≥
//     0 for any reported hit), |δ_D|/q̂² ≤ ρ = 2κ/(1 − κ) and ã|t̃|/|q̂| ≤ (1 + γ(3))(1 + ρ), so
//     |G| ≤ γ(3)(ã t̃² + (1 + γ(3))²(1 + ρ)|δ_D|/ã)/(1 − γ(3)) + γ(3)|Ĉ|
//           + ((1 + γ(3))(1 + ρ) + 1)(1 + γ(3))|δ_D|/ã;
//     or, signed: C̃ = Ĉ + δ_D/ã, so ã(t̃ − T2) = (δ_D + ãηC̃)/q̂ and, with q̂ = ãT1,
//     G(t̃) = (δ_D/ã + ηC̃)(t̃ − T1)/T1: (4)'s δ_D/ã cancels against it, leaving
//     f(t̃) = (f − G − δ_D/ã)(t̃) + (δ_D/ã)·t̃/T1 + ηC̃(t̃/T1 − 1), and |t̃/T1| = ã|t̃|/|q̂| ≤ s:
//     |f(t̃)| ≤ E_a·t̃² + 2E_β|t̃| + E_C + s·|δ_D|/ã + γ(3)(1 + s)|C̃|, s = (1 + γ(3))(1 + ρ) (4′)
//     (far from the sphere δ_D is most of the error: (4) pays it three times, (4′) once);
//   textbook (β̃ ± √D̃)/ã: t̃ = (T + e/(2ã))(1 + ε), |e| ≤ 2u√D̃ + u|numerator|, so
//     |G| ≤ (ã|t̃| + |β̃| + √D̃)(u|T| + (1 + u)|e|/(2ã)).
// The rounding α of o − m enters as an origin moved by α (after it the code computes exactly
// what it computes for o′ = m + fl(o − m)): the bound is o′'s, with o′ − m exact, plus |α|.
// Every term is homogeneous of degree 0 in d: with |t̃·d| ≤ |W| (the travel), |β̃| ≤ |d|F(1 + γ(4))
// (F ≥ |o′ − m|), ã ≥ |d|²(1 − γ(3)), each is a number of the scene. The re-hit side: a ray from
// an origin δ outside, going away (b ≥ 0), is reported only if C̃ ≤ 0, or b̃ < 0 by rounding with
// b̃²(1 + κ) ≥ 4ãC̃(1 − κ) (stable: b̃² ≤ 4γ(4)²|d|²F′²), or the textbook's √disc exceeds b̃,
// which needs 4ãC̃(1 − κ) < κb̃²; c = δ(2R + δ) ≥ 2Rδ beyond E_C plus that rules all out.
//
// Watertight (Woop, Benthin & Wald; variants.cpp watertight, either edge rule: top-left only turns
// hits into misses). Axes kx, ky, kz with |d_kz| the largest, so the exact shear S = d_kx/d_kz has
// |S| ≤ 1 and s̃x = S(1 + δ). With A_i = v_i − o exact, the exact sheared coordinates are
// X_i = A_i,kx − S·A_i,kz, the exact edge functions U_i (U_0 = X_2Y_1 − Y_2X_1, opposite v_0),
// depths Z_i = A_i,kz/d_kz, and N = Σ U_i Z_i, D = Σ U_i = n·d/d_kz (±): t = N/D, and the point
// o + t̃·d lies off the plane by |N − t̃·D|·|d_kz|/|n|. The code computes ũ_i = U_i + e_i,
// z̃_i = fl(fl(1/d_kz)·ã_i,kz), Ñ = fl-dot(ũ, z̃) = Σ ũ_i z̃_i + ρ_N, D̃ = Σ ũ_i + ρ_D and
// t̃ = fl(Ñ/D̃) = (Ñ/D̃)(1 + θ). Since Ñ − t̃D̃ = −θÑ, exactly
//     N − t̃D = Σ ũ_i(Z_i − z̃_i) − ρ_N + t̃ρ_D − θÑ − Σ e_i(Z_i − t̃).                 (5)
// Where (1) would pay for the depths Z_i (the distance to the origin) in every edge function's
// error, (5) pays only for Z_i − t̃: for any point P of the ray, X_i = (v_i − P)_kx − S(v_i − P)_kz,
// and Z_i − t̃ = (v_i − P)_kz/d_kz, for P = o + t̃d, within the point's rounding r of p̃, which lies
// in the domain. So, per vertex, with E_i bounding |v_i − x| over x in the domain, axis by axis:
//     |X_i| ≤ E_i,kx + r_kx + E_i,kz + r_kz,  |Z_i − t̃|·|d_kz| ≤ E_i,kz + r_kz,
// and e_i follows by step 1 from those magnitudes and ã_i's errors u·|A_i| (a zero edge function
// recomputed in the wider type errs by at most 2u of its value, Kahan's as float's, below step 1's
// 2u of its two products). A reported hit has ũ_i of one sign, so Σ|ũ_i| = |D̃ − ρ_D| ≤ |D| + Σ|e_i|
// ≤ |n|₁ + Σ|e_i| =: S_u (|D| = |n·d|/|d_kz| ≤ Σ_k |n_k|·|d_k/d_kz| ≤ |n|₁). With |ρ_N| ≤ γ(3)Σ|ũ_i z̃_i|,
// |ρ_D| ≤ γ(2)Σ|ũ_i|, |z̃_i − Z_i|·|d_kz| ≤ ζ_i = err_i + γ(2)(|A_i,kz| + err_i) and |t̃·d_kz| ≤ W_kz:
//     |N − t̃D|·|d_kz| ≤ S_u(max ζ_i + γ(3)·max|z̃_i d_kz|) + W_kz·S_u(γ(2) + g(1 + γ(2)))
//                      + |Σ e_i·(v_i − P)_kz|,                                         (6)
// g = u/(1 − u), divided by |n| plus (2)'s rounding of the point, for each of the three axes kz.
// The domain is Möller–Trumbore's for the same triangle, so both are judged on the same hits.
// The last term, split: ũ_i = U_i(X̃, Ỹ) + ρ_i, |ρ_i| ≤ γ(2)(|X̃_c Ỹ_b| + |Ỹ_c X̃_b|) (U_i =
// X_c Y_b − Y_c X_b), and U_i is bilinear, so U_i(X̃, Ỹ) − U_i is its first order in ΔX, ΔY plus
// ΔX_c ΔY_b − ΔY_c ΔX_b. At first order the S terms cancel: Σ_i (∂U_i/∂X_j)(v_i − P)_kz = ±f_j,kx
// and Σ_i (∂U_i/∂Y_j)(v_i − P)_kz = ±f_j,ky, f_j = (v_a − P) × (v_b − P) for the two vertices
// after j. Of ΔX_j, the shear's rounding δ·S·A_j,kz is common to the three: it is the move of d_kx
// to d_kx(1 + δ), under which N = ±n·(v_0 − o)/d_kz stays and D = ±n·d/d_kz moves by δ·n_kx·S,
// so it adds at most u·W_kx·|n_kx| (ΔX′, ΔY′: the rest of the errors, by step 1):
//     |Σ e_i (v_i − P)_kz| ≤ u(W_kx|n_kx| + W_ky|n_ky|) + Σ_j (|ΔX′_j||f_j,kx| + |ΔY′_j||f_j,ky|)
//                            + Σ_i (|ΔX_c ΔY_b| + |ΔY_c ΔX_b| + |ρ_i|)(E_i,kz + r_kz).       (8)
// |f_j| is bounded two ways, the smaller taken: f_j is affine in P, so its size is largest at the
// domain's corners (P within r of them: plus r times its gradient); or, with P = P₀ + h·n̂ (P₀ on
// the plane), f_j = β_j·n + h·n̂ × (v_b − v_a) (β_j, P's barycentric, is constant along n: at the
// corners too), and h = |N − t̃D|·|d_kz|/|n| is what is bounded: moved to the left, the bound is
// divided by 1 − c, c = Σ_j (|ΔX′_j| + |ΔY′_j|)·|v_a − v_b|/|n|, where c ≤ 1/2.
// (8') A third way, the ray's own barycentrics. The first-order identity holds at any point Q of
// the ray (X_i, Y_i are the same from any); at the exact plane hit X = o + t·d, f_j(X) = β_j·n,
// β_j = U_j/D. So Σ_i e_i(v_i − P)_kz = Σ_i e_i(v_i − X)_kz + (t − t̃)d_kz·Σ_i e_i, where
// |(t − t̃)d_kz| = H/|D| (H = |N − t̃D|·|d_kz|, what is bounded) and, in the second-order and ρ_i
// terms (w: their coefficients' sum), |(v_i − X)_kz| ≤ E_i,kz + r_kz + H/|D|. A reported hit's ũ_i
// share a sign: Σ|β_j| ≤ (Σ|ũ_j| + Σ|e_j|)/|D| ≤ 1 + 2Σ|e_i|/|D|. For a ray with |D| ≥ λ·T,
// T = Σ|e_i| + w,
//     H·(1 − 1/λ) ≤ [(6) or (6')] + u(W_kx|n_kx| + W_ky|n_ky|)
//                   + (1 + 2/λ)·max_j (|ΔX′_j||n_kx| + |ΔY′_j||n_ky|);
// for a ray with |D| < λ·T, (6') holds with |n·t̃d| = |D|·|t̃d_kz| < λ·T·W_kz and (8) as it stands.
// Each λ gives a bound, the larger of the two cases; the smallest over λ = 8, 64, 512, 4096 is
// taken. A steep ray thus pays its edge errors once (near a vertex, that vertex's), not the
// domain corners' up to 3 times; a grazing one has almost no depth term left.
// Re-hits as for (3): from o′ δ off on the side it leaves to, N and −t̃D have one sign, so
// |N| + t̃|D| = |N − t̃D|, and g·t̃|D̃| ≤ g·t̃(|D| + Σ|e_i| + |ρ_D|) leaves, with g < 1 − c,
//     δ·|n| ≤ S_u(max ζ_i + γ(3)·max|z̃_i d_kz|) + W′_kz(γ(2)(1 + g)S_u + g·Σ|e_i|)
//            + |Σ e_i·(v_i − P)_kz|,                                                    (7)
// over 1 − c the projected way. (7) is a polynomial of degree 3 with nonnegative coefficients in
// how far the origins reach beyond the domain (ζ, e and r grow linearly with it, S_u with e),
// over a constant: below a knee K it lies under its chord, beyond it under its value at K times
// (reach/K)³.
//
// Tightenings, each taken as the smaller of two valid bounds. Möller–Trumbore's edges v1 − v0,
// v2 − v0 are rounded once per triangle: their error is computed exactly (0 where Sterbenz's lemma
// holds), not bounded by u·|e|. N = e2·(s × e1) is linear in s and D in t·d, so every rounding
// term of step 1 is |an affine function| times constants, convex over a box: evaluated at its
// eight corners with signed values (a sum's magnitude |a + b| there) it is largest at one of
// them. For the watertight test (6'), below, takes a ray's depth and Σ|ũ_i| together.
//
// Hearn–Baker (variants.cpp hearn_baker) computes the discriminant from the centre's distance to
// the line, Δ = R² − |l|², l = f + t*·d (f = o′ − m, t* = β/a, β = −f·d), and D̃ = fl(ã·Δ̃),
// q̂ = β̃ + σ√D̃ (σ = sgn β̃), t̃1 = fl(q/ã), t̃0 = fl(C̃/q). Its D̃ errs in proportion to R², not
// to β̃² + ã|C̃| (|l̃|² ≈ R² even where β and c vanish), so the bound is its own; with |d| = 1 (all
// terms are homogeneous of degree 0 in d) and f(t) = (t − t*)² − Δ (since aΔ = β² − ac):
// (9) Granules. A reported hit has Δ̃ ≥ 0, so |l̃|²(1 − γ3) ≤ r̃2(1 + u): |l̃| ≤ Λ. A positive Δ̃ is
//     fl(r̃2 − L̃) ≥ u·2^⌊log2 r̃2⌋ (exact by Sterbenz where L̃ ≥ r̃2/2, a multiple of L̃'s spacing), so
//     D̃ ≥ (1 − γ3)(1 − u)·u·2^⌊log2 r̃2⌋ =: D_lo: |q̂| = |β̃| + √D̃ never falls below √D_lo.
// (10) The errors, for an origin with |f| ≤ F: E_β = γ3F bounds |β̃ − β|; e* = β̃/ã − t*, |e*| ≤
//     2γ3F/(1 − γ3). The code's projection k̃ = fl(f·d/ã) = −(t* + e*)(1 + ε) leaves ℓ = f − k̃d =
//     l + e′_k·d, |e′_k| ≤ |e*| + u(F + |e*|), and since l ⊥ d, |ℓ|² = |l|² + e′_k² (the projection's
//     error costs its square); l̃ = ℓ + ρ, |ρ| ≤ (u(1 + u)|k̃| + uΛ)/(1 − u). With r̃2 = R²(1 + ε₁),
//     L̃ = |l̃|²(1 + θ), |θ| ≤ γ3, Δ̃ = (r̃2 − L̃)(1 + ε₂):
//       E_Δ := |Δ̃ − Δ| ≤ uR² + e′_k² + 2(Λ + ρ)ρ + ρ² + γ3Λ² + uΔ̃/(1 − u).
//     For the small root, δ = C̃ − Ĉ, Ĉ = (β̃² − D̃)/ã (so that Ĉ/q̂ = β̃/ã − σS, S = √D̃/ã): r̃2
//     cancels in C̃ + Δ̃, and |f|² − |l̃|² = β² − e′_k² − 2ℓ·ρ − |ρ|², so δ = (β² − β̃²/ã) + δ₀ + the
//     last roundings of C̃ and Δ̃ (and D̃'s ε_D·Δ̃), with
//       |δ₀| ≤ e′_k² + 2Λρ + 3ρ² + γ3(F² + Λ²) = d₀ + d₁|β̃| + d₂β̃²  (|ρ| ≤ ρ₀ + ρ₁|β̃| by |k̃|),
//       |β² − β̃²/ã| ≤ E_β(2|β̃| + E_β) + γ3β̃²/(1 − γ3);
//     the last roundings are u-multiples of |C̃| ≤ q̂²/ã + |δ| and Δ̃ ≤ q̂²/(ã(1 − u)): over |q̂|, O(u|q̂|).
// (11) The large root t̃1 = (β̃/ã + σS)(1 + η), |η| ≤ γ3: t̃1 − t* = σS + Z, |Z| ≤ |e*| + γ3|t̃1|/(1 − γ3),
//       |f(t̃1)| ≤ |S² − Δ| + 2S|Z| + Z², |S² − Δ| ≤ (E_Δ + uΔ̃ + γ3|Δ|)/(1 − γ3);
//     a touching ray (Δ̃ = 0, S = 0) is the same with |Δ| ≤ E_Δ.
// (12) The small root t̃0 = (β̃/ã − σS + δ/q̂)(1 + η): t̃0 − t* = Y − σS, |f(t̃0)| ≤ |S² − Δ| + 2S|Y| + Y²
//     with Y = e* + δ/q̂ + ηt̃0/(1 + η). The centre's error and β's cancel to first order:
//     e* + (β² − β̃²/ã)/q̂ = (σ√D̃·e* − β(β̃ − β))/q̂, at most |e*|√D̃/|q̂| + E_β + E_β²/|q̂|, so
//       |Y| ≤ |e*|√D̃/|q̂| + E_β + E_β²/|q̂| + γ3|t̃0|/(1 − γ3) + O(u|q̂|) + d₀/|q̂| + d₁ + d₂|β̃|,
//     where 2S·d₀/|q̂| ≤ 2d₀S/(|β̃| + (1 − γ3)S) (far from the sphere S/|β̃| ≈ R/F: the error of c is
//     paid as γF·R, not γF²), and |q̂| ≥ |β̃| + √D_lo with |β̃| ≥ √(F_a² − (Λ + ρ)²) − E_β for origins
//     at |f| ≥ F_a (a hit's |l| ≤ |ℓ| ≤ Λ + ρ). The origins' |f| is cut into slices [F_a, F_b],
//     geometric beyond R, each bounded with F_b's errors and F_a's |β̃|; the largest is taken.
// (12′) A touching ray's small root (q̂ = β̃, so e* + (β² − β̃²/ã)/β̃ is at most E_β(1 + E_β/|β̃|)):
//     under the nearest rule it is reported only when 0 < t̃0 ≤ t̃1, and under the entering rule
//     only when the code's (p̃ − m)·d < 0, i.e. t̃0 − t* < γ4|p̃ − m| + |α| + |r| (r: the point's
//     rounding); either way |Y| ≤ max(|β̃| + E_β, that, |Z|). With (12)'s |Y| ≤ … + (E_β² + |δ₀|)/|β̃|:
//     the first holds where |β̃| ≤ κ = √(E_β² + |δ₀|), the second, its last term at most κ, where
//     |β̃| > κ: Y² is of order |δ₀|, never unbounded.
// (13) Re-hits: from o′ at R + δ from m, going away (β ≤ 0): c′ ≥ 2Rδ − 2uF′² (o − m's rounding,
//     F′ = R + δ). C̃ > 0 once c′ > E_C = γ4F′² + γ2R², and then a positive root needs β̃ ≥ 0, so
//     |β| ≤ E_β and Δ̃ ≥ 0 needs c′ = β² − Δ ≤ E_β² + E_Δ: no hit once 2Rδ − 2uF′² exceeds both.
// Where it is loose: (12)'s Y² at the smallest D̃ pays d₀²/D_lo, of order 10²·uR², for rays
// leaving the surface tangentially, where the roundings of C̃ and Δ̃ (nearly the same dot product
// there) largely cancel: on balls of radius 0.001 to 3 the bracket reaches 8–10×.
#include "rayproof/verify/offset_bounds.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "rayproof/core/fp.h"
#include "rayproof/core/offset.h"
// GCC, inlining Expansion's merge into the normal's cross product, takes c_[i] (read only for
// i < n_) for uninitialized: a false positive.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include "rayproof/verify/expansion.h"
#pragma GCC diagnostic pop

namespace rayproof {
namespace {

[[gnu::always_inline]] inline double up(double x) { return next_up(x); }
[[gnu::always_inline]] inline double down(double x) { return next_down(x); }

double unit_roundoff(Precision p) { return p == Precision::f32 ? 0x1p-24 : kUnitRoundoff; }
// γ(k) in the precision's unit roundoff, rounded up.
double gamma_up(Precision p, int k) {
  const double u = unit_roundoff(p);
  return up(k * u / down(1 - k * u));
}
// The rounding error of a result y with |y| ≤ mag: half an ulp of y's binade, u·2^⌊log2 |y|⌋ ≤
// u·2^⌊log2 mag⌋ (no underflow, the model's range; a y that rounds up to the next power of two
// errs by half the finer spacing). Up to 2× below u·mag, and what rounding can reach: a witness
// meets it only with a value in the top binade. Valid only for a value computed at that size,
// not for one scaled afterwards (t̃ times D's roundings: 2^⌊·⌋ does not scale).
double half_ulp_at_most(double u, double mag) {
  return mag > 0 && std::isfinite(mag) ? u * std::ldexp(1.0, std::ilogb(mag)) : up(u * mag);
}
// A number as the variant sees it.
double in_precision(Precision p, double x) { return p == Precision::f32 ? double(to_nearest_float(x)) : x; }
Vec3 in_precision(Precision p, const Vec3& v) {
  return {in_precision(p, v.x()), in_precision(p, v.y()), in_precision(p, v.z())};
}

// Step 1: a quantity's exact value, known as an interval [lo, hi] (each end rounded outward; of
// unknown sign: [−mag, mag]), and the computed value's error bound. Where signs are known (at one
// point of a box) a sum's magnitude is |a + b| there, not |a| + |b|; over a box, a formula linear in
// the point (Möller–Trumbore's N in s, D in t·d) has, in each rounding term, |an affine function|
// times constants: the error bound is convex in the point, so its largest value is at a corner.
struct Bounded {
  double lo = 0, hi = 0, err = 0;
  static Bounded within(double mag, double err = 0) { return {-mag, mag, err}; }
  double mag() const { return std::max(std::abs(lo), std::abs(hi)); }
};
using BVec = std::array<Bounded, 3>;

struct RunningBound {
  double u;
  // Each rounding as half an ulp of its result's largest binade (half_ulp_at_most), for values
  // the code computes at their own size; else u times the magnitude (homogeneity holds).
  bool at_size = false;
  double rounding(double mag) const { return at_size ? half_ulp_at_most(u, mag) : up(u * mag); }
  static Bounded input(double mag) { return Bounded::within(mag); }
  // a − b of two exact inputs with |a − b| ≤ mag: one rounding.
  Bounded difference(double mag) const { return Bounded::within(mag, rounding(mag)); }
  // A vertex less an origin, whose rounding difference_rounding bounds by `grid` too (at its own
  // size: the grids do not scale).
  Bounded difference(double mag, double grid) const {
    const double err = rounding(mag);
    return Bounded::within(mag, at_size ? std::min(err, grid) : err);
  }
  Bounded rounded(double lo, double hi, double err) const {  // one rounding of the result
    const double mag = Bounded{lo, hi}.mag();
    return {lo, hi, up(err + rounding(up(mag + err)))};
  }
  Bounded add(const Bounded& a, const Bounded& b) const {
    return rounded(down(a.lo + b.lo), up(a.hi + b.hi), up(a.err + b.err));
  }
  Bounded sub(const Bounded& a, const Bounded& b) const {
    return rounded(down(a.lo - b.hi), up(a.hi - b.lo), up(a.err + b.err));
  }
  Bounded mul(const Bounded& a, const Bounded& b) const {
    const double c[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
    const double lo = down(std::min(std::min(c[0], c[1]), std::min(c[2], c[3])));
    const double hi = up(std::max(std::max(c[0], c[1]), std::max(c[2], c[3])));
    return rounded(lo, hi, up(up(up(a.mag() * b.err) + up(b.mag() * a.err)) + up(a.err * b.err)));
  }
  // x − y of two computed values whose exact difference is known to be at most `mag`.
  Bounded difference_within(const Bounded& x, const Bounded& y, double mag) const {
    return rounded(-mag, mag, up(x.err + y.err));
  }
  // In the order variants.cpp writes them: cross component a_j b_k − a_k b_j, dot (x + y) + z.
  BVec cross(const BVec& a, const BVec& b) const {
    return {sub(mul(a[1], b[2]), mul(a[2], b[1])), sub(mul(a[2], b[0]), mul(a[0], b[2])),
            sub(mul(a[0], b[1]), mul(a[1], b[0]))};
  }
  Bounded dot(const BVec& a, const BVec& b) const {
    return add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]));
  }
};
// The larger magnitude and the larger error of two (the worst of a box's corners).
Bounded worse(const Bounded& a, const Bounded& b) {
  return Bounded::within(std::max(a.mag(), b.mag()), std::max(a.err, b.err));
}
// An exact value known to 2^-45 (Expansion::estimate), with its computed rounding's error.
Bounded signed_of(const Expansion& e, double err) {
  const double est = e.estimate(), slack = up(std::abs(est) * 0x1p-45);
  return {down(est - slack), up(est + slack), err};
}
// The corners of a box.
std::array<Vec3, 8> corners_of(const Bounds& b) {
  std::array<Vec3, 8> c;
  for (int k = 0; k < 8; ++k)
    c[k] = Vec3(k & 1 ? b.hi.x() : b.lo.x(), k & 2 ? b.hi.y() : b.lo.y(), k & 4 ? b.hi.z() : b.lo.z());
  return c;
}

BVec inputs(const Vec3& mags) {
  return {RunningBound::input(mags[0]), RunningBound::input(mags[1]), RunningBound::input(mags[2])};
}

// The exact normal's length from below and its unit components from above. Expansion::estimate
// is within a few ulps of the exact value; 2^-45 covers it with room.
struct NormalBounds {
  double length_lo = 0, length_hi = 0;
  Vec3 unit_abs_hi = Vec3::Zero();
};
NormalBounds normal_bounds(const std::array<Expansion, 3>& n) {
  NormalBounds b;
  double sum = 0;
  Vec3 est;
  for (int i = 0; i < 3; ++i) {
    if (!n[i].valid()) return b;  // outside the proved range: no bound
    est[i] = std::abs(n[i].estimate());
    sum += est[i] * est[i];
  }
  b.length_lo = down(std::sqrt(sum) * (1 - 0x1p-45));
  b.length_hi = up(std::sqrt(sum) * (1 + 0x1p-45));
  if (!(b.length_lo > 0) || !std::isfinite(b.length_hi)) return NormalBounds{};
  for (int i = 0; i < 3; ++i) b.unit_abs_hi[i] = std::min(1.0, up(up(est[i] * (1 + 0x1p-45)) / b.length_lo));
  return b;
}
Expansion exact_difference(double a, double b) { return Expansion(a) - Expansion(b); }
double upper_abs(const Expansion& e) { return up(std::abs(e.estimate()) * (1 + 0x1p-45)); }

// Per axis, the largest |x_i − c_i| over x in the box.
Vec3 reach_from(const Bounds& box, const Vec3& c) {
  Vec3 r;
  for (int i = 0; i < 3; ++i) r[i] = up(std::max(std::abs(box.lo[i] - c[i]), std::abs(box.hi[i] - c[i])));
  return r;
}
// Per axis, the largest |t̃·d_i| of a ray from an origin in a whose computed point p̃ lies in b:
// p̃ = o + t̃·d + r with |r_i| ≤ u|t̃·d_i| + u|p̃_i|/(1 − u) (step 2), so |t̃·d_i| ≤ (|p̃_i − o_i| +
// 2u|p̃_i|)/(1 − u); float's u, the larger, serves both precisions.
Vec3 travel(const Bounds& a, const Bounds& b) {
  constexpr double u = 0x1p-24;
  Vec3 r;
  for (int i = 0; i < 3; ++i) {
    const double apart = up(std::max(std::abs(a.hi[i] - b.lo[i]), std::abs(b.hi[i] - a.lo[i])));
    const double point = std::max(std::abs(b.lo[i]), std::abs(b.hi[i]));
    r[i] = up(up(apart + up(2 * u * point)) / down(1 - u));
  }
  return r;
}
// The box of t̃·d itself (signed) for the same rays: p̃ − o widened by the rounding `travel` allows.
Bounds travel_box(const Bounds& origins, const Bounds& points) {
  Bounds w;
  const Vec3 reach = travel(origins, points);
  for (int i = 0; i < 3; ++i) {
    w.lo[i] = down(points.lo[i] - origins.hi[i]), w.hi[i] = up(points.hi[i] - origins.lo[i]);
    const double r = std::max(0.0, up(reach[i] - std::max(std::abs(w.lo[i]), std::abs(w.hi[i]))));
    w.lo[i] = down(w.lo[i] - r), w.hi[i] = up(w.hi[i] + r);
  }
  return w;
}
Vec3 largest_abs(const Bounds& box) {
  Vec3 r;
  for (int i = 0; i < 3; ++i) r[i] = std::max(std::abs(box.lo[i]), std::abs(box.hi[i]));
  return r;
}
Bounds widened(const Bounds& box, double by) {
  Bounds b = box;
  for (int i = 0; i < 3; ++i) {
    b.lo[i] = down(b.lo[i] - by);
    b.hi[i] = up(b.hi[i] + by);
  }
  return b;
}
Bounds in_precision(Precision p, const Bounds& box) {  // rounding is monotone: points stay inside
  return {in_precision(p, box.lo), in_precision(p, box.hi)};
}

// (2)'s last term: the rounding of o + t·d itself, each of its two roundings half an ulp of its
// result's binade (fl(t̃·d_i) of |t̃·d_i| ≤ W_i, p̃_i of |p̃_i| ≤ P_i).
double point_rounding(Precision p, const Vec3& unit_abs_hi, const Vec3& travel, const Vec3& point_abs) {
  const double u = unit_roundoff(p);
  double sum = 0;
  for (int i = 0; i < 3; ++i)
    sum = up(sum + up(unit_abs_hi[i] * up(half_ulp_at_most(u, travel[i]) + half_ulp_at_most(u, point_abs[i]))));
  return sum;
}

// A quotient t = N/D rounded `roundings` times: (1) divided by |n|, plus the point's rounding (2).
double quotient_point_bound(Precision p, int roundings, const Bounded& N, const Bounded& D_at_travel,
                            const NormalBounds& nb, const Vec3& travel, const Vec3& point_abs) {
  const double gk = gamma_up(p, roundings), g = up(gk / down(1 - gk));
  const double along = up(N.err + up(up(D_at_travel.err * up(1 + g)) + up(g * D_at_travel.mag())));
  return up(up(along / nb.length_lo) + point_rounding(p, nb.unit_abs_hi, travel, point_abs));
}
// (3) divided by |n|.
double quotient_rehit(Precision p, int roundings, double err_N, double err_D, const NormalBounds& nb) {
  const double gk = gamma_up(p, roundings), g = up(gk / down(1 - gk));
  return up(up(err_N + up(err_D * up(1 + g))) / nb.length_lo);
}

// An edge a − b of two vertices as the variant computes it: its rounding is known, not only
// bounded (often 0: Sterbenz, for a small triangle away from the axes' zeros).
Bounded computed_difference(Precision p, double a, double b, const Expansion& exact) {
  const double computed = p == Precision::f32 ? double(float(float(a) - float(b))) : a - b;
  return Bounded::within(upper_abs(exact), upper_abs(Expansion(computed) - exact));
}

// Möller–Trumbore (variants.cpp moller_trumbore): p = d × e2, det = e1·p, q = s × e1,
// t = (e2·q)·(1/det): two roundings in the quotient.
// A triangle as a variant of precision p sees it, its edges and its normal, exact.
struct RoundedTriangle {
  Triangle tri;
  std::array<Expansion, 3> e1x, e2x, nx;
  NormalBounds nb;
};
RoundedTriangle rounded_triangle(Precision p, const Triangle& input) {
  RoundedTriangle r;
  for (int k = 0; k < 3; ++k) r.tri.v[k] = in_precision(p, input.v[k]);
  for (int i = 0; i < 3; ++i) {
    r.e1x[i] = exact_difference(r.tri.v[1][i], r.tri.v[0][i]);
    r.e2x[i] = exact_difference(r.tri.v[2][i], r.tri.v[0][i]);
  }
  const auto& e1x = r.e1x;
  const auto& e2x = r.e2x;
  r.nx = {e1x[1] * e2x[2] - e1x[2] * e2x[1], e1x[2] * e2x[0] - e1x[0] * e2x[2], e1x[0] * e2x[1] - e1x[1] * e2x[0]};
  r.nb = normal_bounds(r.nx);
  return r;
}

std::optional<OffsetProof> moller_trumbore_proof(Precision p, const RoundedTriangle& rt, const Bounds& scene_box) {
  const Triangle& tri = rt.tri;
  const NormalBounds& nb = rt.nb;
  const auto& e1x = rt.e1x;
  const auto& e2x = rt.e2x;
  if (!(nb.length_lo > 0)) return std::nullopt;
  const Bounds box = in_precision(p, scene_box);
  const RunningBound A{unit_roundoff(p)};
  BVec e1, e2;
  for (int i = 0; i < 3; ++i) {
    e1[i] = computed_difference(p, tri.v[1][i], tri.v[0][i], e1x[i]);
    e2[i] = computed_difference(p, tri.v[2][i], tri.v[0][i], e2x[i]);
  }
  // N at its own size (each rounding half an ulp of its binade), or in u·magnitude terms where
  // it is scaled by the reach (homogeneity).
  const RunningBound A_at_size{A.u, true};
  Vec3 s_rounding;  // of s = o − v0 from the scene's origins
  for (int i = 0; i < 3; ++i) s_rounding[i] = difference_rounding(p, tri.v[0][i], box.lo[i], box.hi[i]);
  auto N_at = [&](const Vec3& s_mag, const RunningBound& R) {
    BVec s;
    for (int i = 0; i < 3; ++i) s[i] = R.difference(s_mag[i], s_rounding[i]);
    return R.dot(e2, R.cross(s, e1));
  };
  auto D_at = [&](const Vec3& travel_mag) { return A.dot(e1, A.cross(inputs(travel_mag), e2)); };
  // The same at the corners of a box (convex: the largest there), of s = o − v0 for N, of the
  // travel t·d for D (whose |value| is then |n·t·d|, the g·mag_D of (1)), with signed values.
  BVec se1, se2;
  for (int i = 0; i < 3; ++i) {
    se1[i] = signed_of(e1x[i], e1[i].err);
    se2[i] = signed_of(e2x[i], e2[i].err);
  }
  auto N_over = [&](const Bounds& origins) {
    Bounded most;
    for (const Vec3& c : corners_of(origins)) {
      BVec sv;
      for (int i = 0; i < 3; ++i) {
        const double d = c[i] - tri.v[0][i];  // within an ulp of the exact difference
        const Bounded exact{down(d), up(d)};
        sv[i] = {exact.lo, exact.hi, A.rounding(exact.mag())};  // s = fl(o − v0)
      }
      most = worse(most, A.dot(se2, A.cross(sv, se1)));
    }
    return most;
  };
  // t̃·d = p̃ − o − r: within travel_box.
  auto D_over = [&](const Bounds& origins, const Bounds& points) {
    Bounded most;
    for (const Vec3& c : corners_of(travel_box(origins, points)))
      most = worse(most, A.dot(se1, A.cross({Bounded{c[0], c[0]}, Bounded{c[1], c[1]}, Bounded{c[2], c[2]}}, se2)));
    return most;
  };
  Bounds own;
  for (const Vec3& v : tri.v) own.grow(v);

  // Pass 1 over the scene's box bounds every hit point; pass 2 over the primitive's box widened
  // by pass 1's bound (the domain) is the bound reported. Each the smaller of the per-axis
  // magnitudes' bound and the corners' (both valid; the corners' is smaller where signs cancel).
  const Vec3 s_mag = reach_from(box, tri.v[0]);
  const Bounded N_box = N_over(box);
  // Each of (1)'s three terms holds alone: the smaller of the two ways, term by term (the
  // corners' sums are convex only in u·magnitude terms, so they stay in those).
  auto bound_for = [&](const Bounds& points, bool at_corners) {
    const Vec3 w = travel(box, points);
    Bounded N = N_at(s_mag, A_at_size), D = D_at(w);
    if (at_corners) {
      const Bounded D_corners = D_over(box, points);
      N.err = std::min(N.err, N_box.err);
      D = Bounded::within(std::min(D.mag(), D_corners.mag()), std::min(D.err, D_corners.err));
    }
    return quotient_point_bound(p, 2, N, D, nb, w, largest_abs(points));
  };
  OffsetProof proof;
  // (The first pass only sizes the domain: the cheaper bound serves, within a few ulps as wide.)
  const double coarse = bound_for(box, false);
  if (!std::isfinite(coarse)) return std::nullopt;
  proof.point_box = widened(own, coarse);
  proof.point = std::min(coarse, bound_for(proof.point_box, true));
  // Re-hits: origins within the domain's box widened by `reach`, re-hit points in the domain.
  const Vec3 ones(1, 1, 1);
  const Vec3 near_mag = reach_from(proof.point_box, tri.v[0]);
  const Vec3 rehit_travel = travel(proof.point_box, proof.point_box);
  proof.rehit_base = quotient_rehit(p, 2, N_at(near_mag, A).err, D_at(rehit_travel).err, nb);
  proof.rehit_per_reach = quotient_rehit(p, 2, N_at(ones, A).err, D_at(ones).err, nb);
  return proof;
}

// Watertight: (6) and (7) above.
std::optional<OffsetProof> watertight_proof(Precision p, const RoundedTriangle& rt, const Bounds& scene_box) {
  const auto mt = moller_trumbore_proof(p, rt, scene_box);
  if (!mt) return std::nullopt;
  const Triangle& tri = rt.tri;
  const NormalBounds& nb = rt.nb;
  const auto& nx = rt.nx;
  const Bounds box = in_precision(p, scene_box);
  const Vec3 n_est(nx[0].estimate(), nx[1].estimate(), nx[2].estimate());
  const double u = unit_roundoff(p), g2 = gamma_up(p, 2), g3 = gamma_up(p, 3), g = up(u / down(1 - u));
  const Bounds& domain = mt->point_box;
  // (8): per vertex j and the pair (a, b) after it, f_j(x) = (v_a − x) × (v_b − x) at the domain's
  // corners, per axis, and β_j(x) = n·f_j(x)/|n|² there; the gradients' sizes in x.
  const double g6 = gamma_up(Precision::f64, 6), length_sq_lo = down(nb.length_lo * nb.length_lo);
  std::array<std::array<Vec3, 3>, 8> sub_normal;
  std::array<std::array<double, 3>, 8> beta;
  std::array<Vec3, 3> sub_slope;
  std::array<double, 3> edge_length;
  for (int j = 0; j < 3; ++j) {
    const Vec3& va = tri.v[(j + 1) % 3];
    const Vec3& vb = tri.v[(j + 2) % 3];
    edge_length[j] = up((va - vb).norm() * (1 + 0x1p-50));
    for (int k = 0; k < 3; ++k)
      sub_slope[j][k] = up(up(std::abs(va[(k + 1) % 3] - vb[(k + 1) % 3]) * (1 + 0x1p-50)) +
                           up(std::abs(va[(k + 2) % 3] - vb[(k + 2) % 3]) * (1 + 0x1p-50)));
    for (int c = 0; c < 8; ++c) {
      const Vec3 corner(c & 1 ? domain.hi.x() : domain.lo.x(), c & 2 ? domain.hi.y() : domain.lo.y(),
                        c & 4 ? domain.hi.z() : domain.lo.z());
      const Vec3 qa = va - corner, qb = vb - corner, qc = cross(qa, qb);
      double n_dot = std::abs(n_est.dot(qc)), n_dot_err = 0;
      for (int k = 0; k < 3; ++k) {  // in double: the differences and the cross product within γ(6) of their terms
        const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
        const double err = up(g6 * up(std::abs(qa[k1] * qb[k2]) + std::abs(qa[k2] * qb[k1])));
        sub_normal[c][j][k] = up(std::abs(qc[k]) + err);
        // n·f: the estimate's 2^-45, the dot's rounding and f's error, each against |n_k|.
        n_dot_err = up(n_dot_err + up(std::abs(n_est[k]) * up(1 + 0x1p-44) * up(up(std::abs(qc[k]) * 0x1p-44) + err)));
      }
      beta[c][j] = up(up(n_dot + n_dot_err) / length_sq_lo);
    }
  }
  const Vec3 n_abs(upper_abs(nx[0]), upper_abs(nx[1]), upper_abs(nx[2]));
  const double n_1 = up(up(n_abs[0] + n_abs[1]) + n_abs[2]);  // |D| = |n·d|/|d_kz| ≤ |n|₁
  // |D|·|t̃·d_kz| = |n·t̃d|: largest at a corner of the travel box (the estimate's 2^-45 and the
  // double dot's rounding covered by 2^-40 of its terms).
  auto n_dot_travel = [&](const Bounds& origins) {
    double most = 0;
    for (const Vec3& w : corners_of(travel_box(origins, domain))) {
      double terms = 0;
      for (int k = 0; k < 3; ++k) terms = up(terms + up(std::abs(n_est[k]) * std::abs(w[k])));
      most = std::max(most, up(std::abs(n_est.dot(w)) + up(terms * 0x1p-40)));
    }
    return most;
  };
  // A bound on |N − t̃D|·|d_kz| two ways, (8): `corners` takes |f_j| at the domain's corners;
  // `projected` takes f_j = β_j·n + h·n̂ × (v_b − v_a), over 1 − c.
  struct Along {
    double corners, projected;
  };
  // The rounding of each ã_i,k = v_i,k − o_k from the scene's origins, once for the three axes kz.
  std::array<Vec3, 3> a_rounding;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) a_rounding[i][k] = difference_rounding(p, tri.v[i][k], box.lo[k], box.hi[k]);
  // |N − t̃D|·|d_kz| for origins in `origins` (the scene's box unless `rehit`) and dominant axis
  // kz: (6), or (7) for a re-hit.
  auto along = [&](const Bounds& origins, int kz, bool rehit) {
    const int kx = (kz + 1) % 3, ky = (kz + 2) % 3;
    const double n_w = rehit ? 0 : n_dot_travel(origins);
    const Vec3 W = travel(origins, domain), P = largest_abs(domain);
    Vec3 r;
    for (int i = 0; i < 3; ++i) r[i] = up(up(u * W[i]) + up(u * P[i] / down(1 - u)));
    const double r_max = r.maxCoeff();
    // The hit side's roundings at their own size; the re-hit side's stay in u·magnitude terms,
    // where (7)'s growth in the reach (a polynomial, its chord) is what is used.
    const RunningBound R{u, !rehit};
    // The shear's own rounding s̃ = S(1 + δ) is common to the three vertices: it is (8)'s last
    // term. X_rest, Y_rest carry every other error.
    const Bounded shear = Bounded::within(1, u), shear_rest = Bounded::within(up(1 + u));
    std::array<Bounded, 3> X, Y, X_rest, Y_rest;
    double zeta = 0, z_mag = 0, a_err = 0;  // a_err: the largest rounding of ã_i,kz
    std::array<double, 3> depth;
    for (int i = 0; i < 3; ++i) {
      const Vec3 far = reach_from(origins, tri.v[i]), E = reach_from(domain, tri.v[i]);
      auto a = [&](int k) { return R.difference(far[k], a_rounding[i][k]); };  // R is at size unless rehit
      const Bounded az = a(kz), ax = a(kx), ay = a(ky);
      a_err = std::max(a_err, az.err);
      depth[i] = up(E[kz] + r[kz]);
      X[i] = R.difference_within(ax, R.mul(shear, az), up(up(E[kx] + r[kx]) + depth[i]));
      Y[i] = R.difference_within(ay, R.mul(shear, az), up(up(E[ky] + r[ky]) + depth[i]));
      X_rest[i] = R.difference_within(ax, R.mul(shear_rest, az), X[i].mag());
      Y_rest[i] = R.difference_within(ay, R.mul(shear_rest, az), Y[i].mag());
      zeta = std::max(zeta, up(az.err + up(g2 * up(far[kz] + az.err))));
      z_mag = std::max(z_mag, up(up(far[kz] + az.err) * up(1 + g2)));
    }
    // e_i bounded whole (for S_u), and (8): Σ e_i·(v_i − P)_kz, first order at the corners.
    auto edge_err = [&](int i, int j) { return R.add(R.mul(X[i], Y[j]), R.mul(Y[i], X[j])).err; };
    const std::array<double, 3> e = {edge_err(2, 1), edge_err(0, 2), edge_err(1, 0)};  // opposite v_0, v_1, v_2
    const double sum_e = up(up(e[0] + e[1]) + e[2]), S_u = up(n_1 + sum_e);
    const double common = up(up(u * up(W[kx] * n_abs[kx])) + up(u * up(W[ky] * n_abs[ky])));
    // Per vertex, |ΔX′_j||n_kx| + |ΔY′_j||n_ky|: its edge errors against a normal's share ((8), (8')).
    std::array<double, 3> against_n;
    for (int j = 0; j < 3; ++j) against_n[j] = up(up(X_rest[j].err * n_abs[kx]) + up(Y_rest[j].err * n_abs[ky]));
    double at_corners = common, projected = common, c_sum = 0;
    for (int j = 0; j < 3; ++j) c_sum = up(c_sum + up(up(X_rest[j].err + Y_rest[j].err) * edge_length[j]));
    const double sqrt3_r = up(up(std::sqrt(3.0)) * r_max);
    for (int c = 0; c < 8; ++c) {
      double sum = 0, sum_projected = 0;
      for (int j = 0; j < 3; ++j) {
        sum = up(up(sum + up(X_rest[j].err * up(sub_normal[c][j][kx] + up(r_max * sub_slope[j][kx])))) +
                 up(Y_rest[j].err * up(sub_normal[c][j][ky] + up(r_max * sub_slope[j][ky]))));
        const double b = up(beta[c][j] + up(up(sqrt3_r * edge_length[j]) / nb.length_lo));
        sum_projected = up(sum_projected + up(b * against_n[j]));
      }
      at_corners = std::max(at_corners, up(common + sum));
      projected = std::max(projected, up(common + sum_projected));
    }
    double weighted_e = 0, second_sum = 0;  // second_sum: the same without the depths
    for (int i = 0; i < 3; ++i) {
      const Bounded &xc = X[(i + 2) % 3], &yb = Y[(i + 1) % 3], &yc = Y[(i + 2) % 3], &xb = X[(i + 1) % 3];
      const double second = up(up(xc.err * yb.err) + up(yc.err * xb.err));
      const double rounding = up(g2 * up(up(up(xc.mag() + xc.err) * up(yb.mag() + yb.err)) +
                                         up(up(yc.mag() + yc.err) * up(xb.mag() + xb.err))));
      weighted_e = up(weighted_e + up(depth[i] * up(second + rounding)));
      second_sum = up(second_sum + up(second + rounding));
    }
    const double per_travel =
        rehit ? up(up(up(g2 * up(1 + g)) * S_u) + up(g * sum_e)) : up(S_u * up(g2 + up(g * up(1 + g2))));
    const double rest_plain = up(up(up(S_u * up(zeta + up(g3 * z_mag))) + weighted_e) + up(W[kz] * per_travel));
    // The same terms with the depth and Σ|ũ_i| of one ray together (6'): with α_i the rounding
    // of ã_i,kz, ζ_i + γ(3)|z̃_i d_kz| ≤ α_i·a_coef + |A_i,kz|·z_coef (the depth's two roundings
    // and the dot's γ(3), on |ã| ≤ |A| + α), |A_i,kz| ≤ |t̃·d_kz| + E_i,kz + r_kz (v_i − p̃, then
    // p̃ − o), Σ|ũ_i| ≤ |D| + Σ|e_i|, and |D|·|t̃·d_kz| = |n·t̃d|, at most `n_travel` (n_w, and at
    // most |n|₁·W_kz). Taking |D| ≤ |n|₁ and the depth ≤ W_kz apart, as (6) does, pays for a
    // direction along n and a travel along kz at once, which no ray has. α_i the smaller of
    // u·|A_i,kz| (joint too) and its grid bound a_err (difference_rounding) times S_u.
    const double a_coef = up(up(1 + g2) + up(g3 * up(1 + g2)));
    const double z_coef = up(g2 + up(g3 * up(1 + g2)));
    const double kappa = up(g2 + up(g * up(1 + g2)));
    double near = 0;  // the largest E_i,kz
    for (int i = 0; i < 3; ++i) near = std::max(near, reach_from(domain, tri.v[i])[kz]);
    near = up(near + r[kz]);
    auto joint_rest = [&](double n_travel) {
      const double depth_sum = up(up(n_travel + up(n_1 * near)) + up(sum_e * up(W[kz] + near)));
      const double rounding_a = std::min(up(up(u * a_coef) * depth_sum), up(up(a_coef * a_err) * S_u));
      const double joint =
          up(up(up(up(z_coef + kappa) * n_travel) + up(z_coef * up(depth_sum - n_travel))) + rounding_a);
      return std::min(rest_plain, up(up(joint + up(kappa * up(W[kz] * sum_e))) + weighted_e));
    };
    const double rest = rehit ? rest_plain : joint_rest(std::min(n_w, up(n_1 * W[kz])));
    const double c = up(c_sum / nb.length_lo);
    Along way{up(rest + at_corners), c <= 0.5 ? up(up(rest + projected) / down(1 - c)) : INFINITY};
    if (rehit) return way;
    // (8'): a steep ray's edge errors weighted by its own barycentrics, a grazing ray's depth
    // term nearly gone; for each λ the larger of the two, and the smallest over λ.
    const double M = std::max({against_n[0], against_n[1], against_n[2]});
    const double T = up(sum_e + second_sum);
    for (const double lambda : {8.0, 64.0, 512.0, 4096.0}) {
      const double steep = up(up(up(rest + common) + up(up(1 + 2 / lambda) * M)) / down(1 - 1 / lambda));
      const double grazing_rest = joint_rest(std::min({n_w, up(n_1 * W[kz]), up(up(lambda * T) * W[kz])}));
      way.corners = std::min(way.corners, std::max(steep, up(grazing_rest + at_corners)));
      if (c <= 0.5)
        way.projected = std::min(way.projected, std::max(steep, up(up(grazing_rest + projected) / down(1 - c))));
    }
    return way;
  };
  // Over the three dominant axes, divided by |n|: each way, and the better.
  auto worst = [&](const Bounds& origins, bool rehit) {
    Along w{0, 0};
    for (int kz = 0; kz < 3; ++kz) {
      const Along a = along(origins, kz, rehit);
      w = {std::max(w.corners, a.corners), std::max(w.projected, a.projected)};
    }
    return Along{up(w.corners / nb.length_lo), up(w.projected / nb.length_lo)};
  };
  OffsetProof proof;
  proof.point_box = domain;
  const Along at_hit = worst(box, false);
  proof.point = up(std::min(at_hit.corners, at_hit.projected) +
                   point_rounding(p, nb.unit_abs_hi, travel(box, domain), largest_abs(domain)));
  if (!std::isfinite(proof.point)) return std::nullopt;
  // Re-hits: each way is (7) over 1 or 1 − c, a polynomial in the reach over a constant; below the
  // knee (the domain's size) the line through its values at 0 and the knee, the one that starts
  // lower. Beyond it the corners' way, convex (a maximum of polynomials with nonnegative
  // coefficients): its chord up to a second knee, where the terms of degree 2 and 3 (u² and u³
  // times the reach's powers) are still 2^-10 of the linear ones, then (reach/knee2)³.
  proof.rehit_knee = up((domain.hi - domain.lo).maxCoeff());
  proof.rehit_knee2 = up(up(proof.rehit_knee * 0x1p-10) / u);
  const Along at_0 = worst(domain, true), at_knee = worst(widened(domain, proof.rehit_knee), true);
  const bool projected = at_knee.projected < INFINITY && at_0.projected < at_0.corners;
  proof.rehit_base = projected ? at_0.projected : at_0.corners;
  const double knee_value = projected ? at_knee.projected : at_knee.corners;
  proof.rehit_per_reach = up(std::max(0.0, up(knee_value - proof.rehit_base)) / down(proof.rehit_knee));
  proof.rehit_at_knee = std::max(at_knee.corners, knee_value);  // never below the line that ends there
  proof.rehit_at_knee2 = worst(widened(domain, proof.rehit_knee2), true).corners;
  return proof;
}

// The plane (variants.cpp direct): t = (off − n·o) / (n·d), one rounding in the quotient. The
// plane has no box of its own: its domain is the scene's box.
std::optional<OffsetProof> plane_proof(Precision p, const Plane& input, const Bounds& scene_box) {
  const Vec3 n = in_precision(p, input.normal);
  const double off = in_precision(p, input.offset);
  const Bounds box = in_precision(p, scene_box);
  const std::array<Expansion, 3> nx = {Expansion(n.x()), Expansion(n.y()), Expansion(n.z())};
  const NormalBounds nb = normal_bounds(nx);
  if (!(nb.length_lo > 0)) return std::nullopt;
  const RunningBound A{unit_roundoff(p)};
  const BVec nv = inputs(n.cwiseAbs());
  // N at its own size on the hit side, in u·magnitude terms where scaled by the reach.
  const RunningBound A_at_size{A.u, true};
  auto N_at = [&](const Vec3& origin_mag, double off_mag, const RunningBound& R) {
    return R.add(RunningBound::input(off_mag), R.dot(nv, inputs(origin_mag)));
  };
  auto D_at = [&](const Vec3& travel_mag) { return A.dot(nv, inputs(travel_mag)); };
  auto bound_for = [&](const Bounds& points) {
    const Vec3 w = travel(box, points);
    return quotient_point_bound(p, 1, N_at(largest_abs(box), std::abs(off), A_at_size), D_at(w), nb, w,
                                largest_abs(points));
  };
  OffsetProof proof;
  const double coarse = bound_for(box);
  if (!std::isfinite(coarse)) return std::nullopt;
  proof.point_box = widened(box, coarse);
  // An axis-aligned plane pins its points' coordinate on that axis (within the coarse bound).
  const int nonzero = (n.x() != 0) + (n.y() != 0) + (n.z() != 0);
  for (int i = 0; i < 3 && nonzero == 1; ++i)
    if (n[i] != 0) {
      const double at = off / n[i];
      proof.point_box.lo[i] = down(down(at) - coarse);
      proof.point_box.hi[i] = up(up(at) + coarse);
    }
  proof.point = std::min(coarse, bound_for(proof.point_box));
  const Vec3 ones(1, 1, 1);
  const Vec3 rehit_travel = travel(proof.point_box, proof.point_box);
  proof.rehit_base =
      quotient_rehit(p, 1, N_at(largest_abs(proof.point_box), std::abs(off), A).err, D_at(rehit_travel).err, nb);
  proof.rehit_per_reach = quotient_rehit(p, 1, N_at(ones, 0, A).err, D_at(ones).err, nb);
  return proof;
}

// The box variants: each face's coordinate (the derivation above).
std::optional<OffsetProof> box_proof(Precision p, bool robust, const Box& input, const Bounds& scene_box) {
  const Bounds own = {in_precision(p, input.min), in_precision(p, input.max)};
  const Bounds box = in_precision(p, scene_box);
  const double u = unit_roundoff(p);
  // Entries come from anywhere in the scene's box; exits from inside the box itself, so their
  // travel is at most its extent.
  const double entry = gamma_up(p, robust ? 4 : 3);
  double exit = gamma_up(p, 3);
  if (robust) {
    // K̃ as robust_slab computes it in its own precision.
    const double widen =
        p == Precision::f32 ? double(1.0f + 2 * (3 * 0x1p-24f / (1 - 3 * 0x1p-24f))) : 1 + 2 * gamma(3);
    exit = up(up(widen - 1) + up(widen * gamma_up(p, 5)));
  }
  auto bound_for = [&](const Bounds& points) {
    const Vec3 point_abs = largest_abs(points);
    double worst = 0;
    for (int i = 0; i < 3; ++i) {
      const double from_scene =
          up(std::max(std::max(std::abs(own.lo[i] - box.lo[i]), std::abs(box.hi[i] - own.lo[i])),
                      std::max(std::abs(own.hi[i] - box.lo[i]), std::abs(box.hi[i] - own.hi[i]))));
      const double from_inside = up(own.hi[i] - own.lo[i]);
      const double along = std::max(up(entry * from_scene), up(exit * from_inside));
      worst = std::max(worst, up(along + up(u * point_abs[i] / down(1 - u))));
    }
    return worst;
  };
  OffsetProof proof;
  const double coarse = bound_for(box);
  if (!std::isfinite(coarse)) return std::nullopt;
  proof.point_box = widened(own, coarse);
  proof.point = std::min(coarse, bound_for(proof.point_box));
  return proof;  // re-hits: none from strictly outside (rehit 0)
}

// The subtraction õc = fl(o − m) = (o − m) + α is a sphere formula's only use of o: from there it
// computes exactly what it computes, without that rounding, for the origin o′ = m + õc. So a bound
// is o′'s, its õc exact (|õc_i| ≤ |o_i − m_i|(1 + u)), and the point o + t̃·d lies within |α| of
// o′ + t̃·d: |α| is added. Carried as errors of õc instead, α would be paid in c and in β·t̃ at
// |o − m| times its size each, where the point moves by |α| only. For origins `reach` from m per
// axis: |α| and |õc| from above.
struct MovedOrigin {
  double alpha = 0, F = 0;
};
MovedOrigin moved_origin(double u, const Vec3& reach) {
  double alpha_squared = 0;
  for (int i = 0; i < 3; ++i) {
    const double a_i = half_ulp_at_most(u, reach[i]);
    alpha_squared = up(alpha_squared + up(a_i * a_i));
  }
  return {up(std::sqrt(alpha_squared) * (1 + 0x1p-50)), up(up(reach.norm() * (1 + 0x1p-50)) * (1 + u))};
}

// A sphere's point bound from |f(t̃)| (the derivation above (4)): h ≤ |f(t̃)|/(2R − h₁) where
// h₁ = |f(t̃)|/R < 2R, plus |α| (o − m's rounding, a moved origin) and the point's own rounding; first
// over the scene's box, then over the points that bound allows. `f_bound(points, w)`: |f(t̃)| for
// hits whose computed point lies in `points`, w the travel to them.
template <class FBound>
std::optional<OffsetProof> sphere_point_proof(Precision p, const Vec3& m, double R, double alpha, const Bounds& box,
                                              const FBound& f_bound) {
  auto bound_for = [&](const Bounds& points) {
    const Vec3 w = travel(box, points);
    const double f = f_bound(points, w);
    const double h1 = up(f / R), two_R = 2 * R;  // exact: a power of two times R
    const double h = h1 < two_R ? std::min(h1, up(f / down(two_R - h1))) : h1;
    return up(up(h + alpha) + point_rounding(p, Vec3(1, 1, 1), w, largest_abs(points)));
  };
  Bounds own;
  own.grow(Vec3(down(m.x() - R), down(m.y() - R), down(m.z() - R)));
  own.grow(Vec3(up(m.x() + R), up(m.y() + R), up(m.z() + R)));
  OffsetProof proof;
  const double coarse = bound_for(box);
  if (!std::isfinite(coarse)) return std::nullopt;
  proof.point_box = widened(own, coarse);
  proof.point = std::min(coarse, bound_for(proof.point_box));
  return proof;
}

enum class SphereFormula { textbook, stable, stable_fma };

// The sphere variants (the derivation above (4)).
std::optional<OffsetProof> sphere_proof(Precision p, SphereFormula formula, const Sphere& input,
                                        const Bounds& scene_box) {
  const Vec3 m = in_precision(p, input.center);
  const double R = in_precision(p, input.radius);
  if (!(R > 0)) return std::nullopt;
  const Bounds box = in_precision(p, scene_box);
  const double u = unit_roundoff(p), g3 = gamma_up(p, 3), g4 = gamma_up(p, 4), g6 = gamma_up(p, 6);
  const double kappa = gamma_up(p, formula == SphereFormula::stable_fma ? 3 : 2), rho = up(2 * kappa / down(1 - kappa));
  const RunningBound A{u};
  // The origin o′ = m + fl(o − m) (moved_origin): its õc exact, |α| added to the point.
  const Vec3 f_mag = reach_from(box, m);
  const MovedOrigin moved = moved_origin(u, f_mag);
  const double alpha = moved.alpha, F = moved.F;  // F ≥ |õc|
  BVec oc;
  for (int i = 0; i < 3; ++i) oc[i] = RunningBound::input(up(f_mag[i] * (1 + u)));
  const Bounded C = A.add(A.dot(oc, oc), A.mul(RunningBound::input(R), RunningBound::input(R)));
  const double C_computed = up(C.mag() + C.err);                                   // |C̃|
  const double Fb = up(F * (1 + g4));                                              // |β̃|/|d|
  const double delta_D = up(kappa * up(up(Fb * Fb / down(1 - g3)) + C_computed));  // |δ_D|/ã
  const double C_hat = up(C_computed + delta_D);                                   // |Ĉ|
  // √D̃/|d|, two ways: D̃ ≤ β̃² + ã|Ĉ|; or D̃ = D + (β̃² − β²) − (ãC̃ − ac) + δ_D with the exact
  // D = β² − ac = |d|²R² − |d × (o − m)|² ≤ |d|²R², |β̃² − β²| ≤ E_β(2|β| + E_β) and
  // |ãC̃ − ac| ≤ ãE_C + E_a|c|, E_a ≤ γ(3)|d|²: far from the sphere √D̃ is about |d|R, not |d|F.
  const double E_beta = A.dot(inputs(Vec3(1, 1, 1)), oc).err;  // E_β/|d| (|d_i| ≤ |d|)
  const double D_near = up(up(up(up(R * R) + up(E_beta * up(up(2 * F) + E_beta))) + up(up(1 + g3) * C.err)) +
                           up(up(g3 * C.mag()) + up(up(1 + g3) * delta_D)));
  const double Sd =
      std::min(up(Fb + std::sqrt(up(up(1 + g3) * C_hat)) * (1 + 0x1p-50)), up(std::sqrt(D_near) * (1 + 0x1p-50)));
  auto proof = sphere_point_proof(p, m, R, alpha, box, [&](const Bounds&, const Vec3& w) {
    const double Lt = up(w.norm() * (1 + 0x1p-50));                                   // |t̃·d|
    const Bounded a = A.dot(inputs(w), inputs(w));                                    // E_a·t̃² (homogeneity)
    const Bounded beta = A.dot(inputs(w), oc);                                        // E_β·|t̃|
    const double f_minus_G = up(up(up(a.err + up(2 * beta.err)) + C.err) + delta_D);  // (4)
    const double Q = up(up(up(Lt * (1 + g3)) + Fb) + Sd);                             // (ã|t̃| + |β̃| + √D̃)/|d|
    double f_bound;                                                                   // |f(t̃)|
    if (formula == SphereFormula::textbook) {
      const double E0 = up(u * up(Sd + up(up((1 + u) * (1 + u)) * up(Fb + Sd))) / down(1 - g3));  // |e|/(2ã)·|d|
      const double G = up(Q * up(up(u * up(Lt + up((1 + u) * E0)) / down(1 - u)) + up((1 + u) * E0)));
      f_bound = up(f_minus_G + G);
    } else {
      // q/a: t̃ = T1(1 + η), G(t̃) = ãηT1(T1 − T2 + ηT1), |T1 − T2| = 2√D̃/ã, ã|T1| = |β̃| + √D̃.
      const double big = up(up(up(g3 / down(1 - g3)) * Lt) * std::min(Q, up(up(2 * Sd) + up(g3 * up(Fb + Sd)))));
      const double t2 = up(up(Lt * Lt) * (1 + g3));  // ã·t̃²
      const double spread = up(up(1 + g3) * up(1 + rho));
      const double small = up(up(up(g3 * up(t2 + up(up(spread * (1 + g3)) * delta_D))) / down(1 - g3)) +
                              up(up(g3 * C_hat) + up(up(up(spread + 1) * (1 + g3)) * delta_D)));
      // c/q: (4) with |G| above, or (4′), the smaller; q/a: (4).
      const double signed_small = up(up(up(up(a.err + up(2 * beta.err)) + C.err) + up(spread * delta_D)) +
                                     up(up(g3 * up(1 + spread)) * C_computed));
      f_bound = std::max(up(f_minus_G + big), std::min(up(f_minus_G + small), signed_small));
    }
    return f_bound;
  });
  if (!proof) return std::nullopt;
  // Re-hits from origins within point + reach of the surface: F′ = R + point + reach.
  const double coef =
      formula == SphereFormula::textbook
          ? up(kappa * up((1 + g4) * (1 + g4)) / down(down(1 - g3) * down(1 - kappa)))
          : up(up(g4 * g4) * up(up((1 + kappa) * (1 + g4) * (1 + g4)) / down(down(1 - kappa) * down(1 - g3))));
  const double k2 = up(g6 + coef), F0 = up(R + proof->point), two_R = down(2 * R);
  proof->rehit_base = up(up(up(k2 * up(F0 * F0)) + up(g6 * up(R * R))) / two_R);
  proof->rehit_per_reach = up(up(2 * up(k2 * F0)) / two_R);
  proof->rehit_per_reach_squared = up(k2 / two_R);
  return proof;
}

// Hearn–Baker (the derivation (9)–(13) above), for the origin o′ = m + fl(o − m) as the sphere
// variants above, |α| added; in units where |d| = 1 (every term is homogeneous of degree 0 in d).
std::optional<OffsetProof> hearn_baker_proof(Precision p, const Sphere& input, const Bounds& scene_box) {
  const Vec3 m = in_precision(p, input.center);
  const double R = in_precision(p, input.radius);
  if (!(R > 0)) return std::nullopt;
  const Bounds box = in_precision(p, scene_box);
  const double u = unit_roundoff(p), g2 = gamma_up(p, 2), g3 = gamma_up(p, 3), g4 = gamma_up(p, 4);
  const double g3q = up(g3 / down(1 - g3));  // γ3/(1 − γ3): η′, e*'s and ã's relative errors
  // r̃2 = fl(R·R) as the code computes it, and the smallest positive Δ̃ (9).
  const double r2 = p == Precision::f32 ? double(float(R) * float(R)) : R * R;
  const double granule = std::ldexp(u, std::ilogb(r2));
  const double R2 = up(R * R), delta_max = up(up(R2 * (1 + u)) * (1 + u));                   // Δ̃ ≤ r̃2(1 + u)
  const double Lambda = up(std::sqrt(up(up(R2 * (1 + u)) / down(1 - g3))) * (1 + 0x1p-50));  // |l̃|
  const double S_max = up(std::sqrt(up(up(delta_max * (1 + u)) / down(1 - g3))) * (1 + 0x1p-50));
  const double sqrt_D_lo = down(std::sqrt(down(down(1 - g3) * down(down(1 - u) * granule))) * (1 - 0x1p-50));
  // |ρ| ≤ ρ₀ + ρ₁|β̃| (10): |k̃| ≤ |β̃|(1 + u)/(1 − γ3).
  const double rho0 = up(up(u * Lambda) / down(1 - u));
  const double rho1 = up(up(up(u * (1 + u)) * up(1 + u)) / down(down(1 - g3) * down(1 - u)));
  // The errors (10) for origins |o′ − m| ≤ F: E_β, |e*|, |e′_k|, |ρ|, E_Δ, and δ₀ = d₀ + d₁|β̃| + d₂β̃²
  // (its ρ terms 2(Λ + ρ)ρ + ρ² = 2Λρ + 3ρ² expanded in |β̃|: a tangent ray's small β̃ pays less).
  struct Errors {
    double E_beta, e_star, e_k, rho, E_Delta, delta0, d0, d1, d2;
  };
  auto errors = [&](double F) {
    Errors e;
    e.E_beta = up(g3 * F);
    e.e_star = up(2 * up(g3q * F));
    e.e_k = up(e.e_star + up(u * up(F + e.e_star)));
    e.rho = up(rho0 + up(rho1 * up(F * (1 + g3))));
    const double shared = up(up(up(e.e_k * e.e_k) + up(2 * up(up(Lambda + e.rho) * e.rho))) +
                             up(up(e.rho * e.rho) + up(g3 * up(Lambda * Lambda))));
    e.E_Delta = up(up(shared + up(u * R2)) + up(u * delta_max / down(1 - u)));
    e.delta0 = up(shared + up(g3 * up(F * F)));
    e.d0 = up(up(up(e.e_k * e.e_k) + up(g3 * up(up(F * F) + up(Lambda * Lambda)))) +
              up(up(2 * up(Lambda * rho0)) + up(3 * up(rho0 * rho0))));
    e.d1 = up(up(2 * up(Lambda * rho1)) + up(6 * up(rho0 * rho1)));
    e.d2 = up(3 * up(rho1 * rho1));
    return e;
  };
  const MovedOrigin moved = moved_origin(u, reach_from(box, m));
  const double alpha = moved.alpha, F_hi = moved.F;  // F_hi ≥ |õc|
  double F_lo_squared = 0;
  for (int i = 0; i < 3; ++i) {
    const double gap = std::max(0.0, std::max(down(box.lo[i] - m[i]), down(m[i] - box.hi[i])));
    F_lo_squared = std::max(0.0, down(F_lo_squared + down(gap * gap)));
  }
  const double F_lo = std::max(0.0, down(down(std::sqrt(F_lo_squared) * (1 - 0x1p-50)) * (1 - u)));  // ≤ |õc|
  if (!std::isfinite(F_hi)) return std::nullopt;
  // The origins' distances in slices [F_a, F_b], geometric beyond R (the near root's |β̃| from
  // below, (12), needs F_a close to F_b): at most 4,096.
  std::vector<double> cuts{F_lo};
  if (F_hi > std::max(F_lo, R)) {
    const double from = std::max(F_lo, R);
    const double ratio = std::max(1 + 1.0 / 64, std::pow(F_hi / from, 1.0 / 4096));
    if (from > F_lo) cuts.push_back(from);
    for (double x = up(from * ratio); x < F_hi; x = up(x * ratio)) cuts.push_back(x);
  }
  cuts.push_back(std::max(F_lo, F_hi));
  auto proof = sphere_point_proof(p, m, R, alpha, box, [&](const Bounds& points, const Vec3& w) {
    const double L = up(w.norm() * (1 + 0x1p-50));  // |t̃·d|
    const double rounding = point_rounding(p, Vec3(1, 1, 1), w, largest_abs(points));
    const double check = up(up(up(g4 * up(reach_from(points, m).norm() * (1 + 0x1p-50))) + alpha) + rounding);
    double f_bound = 0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
      const double F_a = cuts[k], F_b = cuts[k + 1];
      const Errors e = errors(F_b);
      const double b_hi = up(F_b * (1 + g3));  // |β̃|
      const double l_hi = up(Lambda + e.rho), beta_squared_lo = down(down(F_a * F_a) - up(l_hi * l_hi));
      const double b_lo =
          beta_squared_lo > 0 ? std::max(0.0, down(down(std::sqrt(beta_squared_lo) * (1 - 0x1p-50)) - e.E_beta)) : 0;
      const double q_lo = down(b_lo + sqrt_D_lo);
      const double Delta_abs = up(delta_max + e.E_Delta);
      const double base = up(up(up(e.E_Delta + up(u * delta_max)) + up(g3 * Delta_abs)) / down(1 - g3));  // |S² − Δ|
      const double along = up(e.e_star + up(g3q * L));  // |e*| + |η′t̃|
      // (11) the far root q/a (touching too).
      const double far = up(up(base + up(2 * up(S_max * along))) + up(along * along));
      // (12) the near root c/q with Δ̃ > 0: e* + δ_β/q̂ = (σ√D̃·e* − β·e_β)/q̂, then δ₀/q̂, then the last
      // roundings of C̃ and Δ̃ over |q̂|: T ≤ u₁(|q̂|/ã + |δ|/|q̂|) + (u₁ + u)|q̂|/(ã(1 − u)), u₁ = u/(1 − u)
      // (|Ĉ| ≤ q̂²/ã, Δ̃ ≤ q̂²/(ã(1 − u))), with |δ|/|q̂| ≤ (|δ_β + δ₀|/|q̂| + T's q-terms)/(1 − u₁).
      const double q_hi = up(b_hi + up((1 + g3) * S_max)), u1 = up(u / down(1 - u));
      auto last_roundings = [&](double q_low, bool touching) {
        const double delta_over_q = up(up(up(2 * e.E_beta) + up(g3q * b_hi)) +
                                       up(up(up(e.E_beta * e.E_beta) + e.delta0) / q_low));  // |δ_β + δ₀|/|q̂|
        const double q_over_a = up(q_hi / down(1 - g3));
        const double from_delta = touching ? 0 : up(up(up(u1 + u) * q_over_a) / down(1 - u));  // Δ̃'s: none if 0
        const double q_terms = up(up(u1 * q_over_a) + from_delta);
        const double delta_total = up(up(delta_over_q + q_terms) / down(1 - u1));
        return up(up(u1 * up(q_over_a + delta_total)) + from_delta);
      };
      const double centre = up(up(e.e_star * up(up((1 + g3) * S_max) / up(b_lo + up((1 + g3) * S_max)))) +
                               up(e.E_beta + up(e.E_beta * e.E_beta / q_lo)));
      const double Y_c = up(up(centre + up(g3q * L)) + last_roundings(q_lo, false));
      // δ₀/|q̂| ≤ d₀/(|β̃| + √D_lo) + d₁ + d₂|β̃| (|q̂| ≥ |β̃| + √D_lo, |β̃|/|q̂| ≤ 1).
      const double beta_part = up(e.d1 + up(e.d2 * b_hi));
      const double Y = up(up(Y_c + up(e.d0 / q_lo)) + beta_part);
      const double S_share = up(S_max / down(b_lo + down(down(1 - g3) * S_max)));  // S/|q̂| first: d₀·S may overflow
      const double spread = up(up(2 * up(e.d0 * S_share)) + up(2 * up(S_max * beta_part)));
      const double near = up(up(up(base + up(2 * up(S_max * Y_c))) + spread) + up(Y * Y));
      // (12′) the near root of a touching ray (Δ̃ = 0, q̂ = β̃): |e* + δ_β/β̃| ≤ E_β(1 + E_β/|β̃|).
      const double K = up(up(e.E_beta * e.E_beta) + e.delta0), kappa = up(std::sqrt(K) * (1 + 0x1p-50));
      const double b_split = std::max(b_lo, kappa);
      const double tail = up(up(up(up(g3q * L) + e.E_beta) + up(K / b_split)) + last_roundings(b_split, true));
      double Y_t = tail;
      if (b_lo <= kappa) Y_t = std::max(Y_t, std::max(up(kappa + e.E_beta), std::max(check, along)));
      const double touching = up(e.E_Delta + up(Y_t * Y_t));
      const double worst = std::max(far, std::max(near, touching));
      if (!(worst >= 0)) return double(INFINITY);  // a NaN must not pass for a bound
      f_bound = std::max(f_bound, worst);
    }
    return f_bound;
  });
  if (!proof) return std::nullopt;
  // (13) Re-hits: no hit once 2Rδ exceeds P(F′) = max(E_C, E_β² + E_Δ) + 2uF′² at F′(1 + u),
  // F′ = R + point + reach; each a polynomial in F′ with nonnegative coefficients: the larger
  // coefficient of each degree bounds both.
  const double s = 1 + u, s2 = up(s * s);
  // E_Δ's coefficients in F: e′_k is linear (no constant), ρ = ρ₀ + ρ₁(1 + γ3)F.
  const double e_k1 = errors(1).e_k, rho_per_F = up(rho1 * (1 + g3));
  const double delta_c0 = errors(0).E_Delta;
  const double delta_c1 = up(up(2 * up(Lambda * rho_per_F)) + up(6 * up(rho0 * rho_per_F)));
  const double delta_c2 = up(up(e_k1 * e_k1) + up(3 * up(rho_per_F * rho_per_F)));
  const double c0 = std::max(up(g2 * R2), delta_c0);
  const double c1 = up(delta_c1 * s);
  const double c2 = up(up(std::max(g4, up(up(g3 * g3) + delta_c2)) * s2) + up(2 * u));
  const double F0 = up(R + proof->point), two_R = down(2 * R);
  proof->rehit_base = up(up(up(c0 + up(c1 * F0)) + up(c2 * up(F0 * F0))) / two_R);
  proof->rehit_per_reach = up(up(c1 + up(2 * up(c2 * F0))) / two_R);
  proof->rehit_per_reach_squared = up(c2 / two_R);
  return proof;
}

enum class Formula {
  none,
  moller_trumbore,
  watertight,
  plane_direct,
  slab,
  robust_slab,
  textbook,
  stable,
  stable_fma,
  hearn_baker
};
// The formula a built-in variant computes (its structure-of-arrays twins are bit-identical).
Formula formula_of(const Variant& v) {
  if (v.external != nullptr || v.kernel == nullptr || v.is_oracle) return Formula::none;
  std::string_view name = v.name;
  if (name.ends_with("-batch")) name.remove_suffix(6);
  if (name.ends_with("-f32")) name.remove_suffix(4);
  if (name == "moller-trumbore") return Formula::moller_trumbore;
  if (name == "watertight" || name == "watertight-top-left") return Formula::watertight;
  if (name == "direct") return Formula::plane_direct;
  if (name == "slab") return Formula::slab;
  if (name == "robust-slab") return Formula::robust_slab;
  if (name == "textbook") return Formula::textbook;
  if (name == "stable") return Formula::stable;
  if (name == "stable-fma") return Formula::stable_fma;
  if (name == "hearn-baker") return Formula::hearn_baker;
  return Formula::none;
}
// The batch twins report double but compute in the precision their name says.
Precision precision_of(const Variant& v) {
  return std::string_view(v.name).find("-f32") != std::string_view::npos ? Precision::f32 : v.precision;
}

}  // namespace

double OffsetProof::rehit_at(double reach) const {
  if (reach > rehit_knee2) {  // a cubic with nonnegative coefficients grows at most as (reach/knee2)³
    const double ratio = up(reach / rehit_knee2);
    return up(rehit_at_knee2 * up(ratio * up(ratio * ratio)));
  }
  if (reach > rehit_knee) {  // a convex function under its chord
    const double slope = up(std::max(0.0, up(rehit_at_knee2 - rehit_at_knee)) / down(rehit_knee2 - rehit_knee));
    return up(rehit_at_knee + up(slope * up(reach - rehit_knee)));
  }
  return up(up(rehit_base + up(rehit_per_reach * reach)) + up(rehit_per_reach_squared * up(reach * reach)));
}

std::optional<OffsetProof> offset_proof(const Variant& v, const Shape& shape, const Bounds& scene_box) {
  const Precision p = precision_of(v);
  switch (formula_of(v)) {
    case Formula::moller_trumbore:
      if (const auto* t = std::get_if<Triangle>(&shape))
        return moller_trumbore_proof(p, rounded_triangle(p, *t), scene_box);
      break;
    case Formula::watertight:
      if (const auto* t = std::get_if<Triangle>(&shape)) return watertight_proof(p, rounded_triangle(p, *t), scene_box);
      break;
    case Formula::plane_direct:
      if (const auto* pl = std::get_if<Plane>(&shape)) return plane_proof(p, *pl, scene_box);
      break;
    case Formula::slab:
    case Formula::robust_slab:
      if (const auto* b = std::get_if<Box>(&shape))
        return box_proof(p, formula_of(v) == Formula::robust_slab, *b, scene_box);
      break;
    case Formula::textbook:
    case Formula::stable:
    case Formula::stable_fma:
      if (const auto* sp = std::get_if<Sphere>(&shape)) {
        const SphereFormula f = formula_of(v) == Formula::textbook ? SphereFormula::textbook
                                : formula_of(v) == Formula::stable ? SphereFormula::stable
                                                                   : SphereFormula::stable_fma;
        return sphere_proof(p, f, *sp, scene_box);
      }
      break;
    case Formula::hearn_baker:
      if (const auto* sp = std::get_if<Sphere>(&shape)) return hearn_baker_proof(p, *sp, scene_box);
      break;
    case Formula::none: break;
  }
  return std::nullopt;
}

std::vector<std::string_view> variants_with_offset_proofs() {
  std::vector<std::string_view> names;
  for (const Variant& v : all_variants())
    if (formula_of(v) != Formula::none) names.push_back(v.name);
  return names;
}

// difference_rounding (offset_bounds.h).
// A = v − o rounds to the spacing g of its binade [2^E, 2^(E+1)) (g = 2^(E+1−P), P = 53 or 24).
// Where o's binade is at least A's, o is a multiple of g, so fl(A) − A is v's distance to the
// nearest multiple of g: fixed by v's low bits. A vertex read from a float file and judged in
// double is such a multiple for every origin at least as far out as the vertex's travel: the
// difference is exact there, and only origins of finer spacing (nearer zero, so nearer v in that
// axis) round at all. Those on a grid h < g reach g/2 less v's distance to h's grid; the finest
// (o within 2^-4|v| of zero) half an ulp, u·2^E, half_ulp_at_most's.
double difference_rounding(Precision p, double v, double o_lo, double o_hi) {
  if (v == 0) return 0;                                                                    // fl(0 − o) = −o
  if (!std::isfinite(o_lo) || !std::isfinite(o_hi) || !std::isfinite(v)) return INFINITY;  // `all`: no grids
  const int bits = p == Precision::f32 ? 24 : 53;
  const double u = unit_roundoff(p);
  double most = 0;
  auto off_grid = [&](double g) {  // v's distance to the nearest multiple of g (fmod is exact)
    const double r = std::abs(std::fmod(v, g));
    return std::min(r, g - r);
  };
  // A between a_0 and a_1, from origins whose binade is o_binade (or finer, INT_MIN).
  auto over = [&](double a_0, double a_1, int o_binade) {  // v − o at the range's ends, widened a double
    const double a_lo = down(std::min(a_0, a_1)), a_hi = up(std::max(a_0, a_1));
    const double m_hi = std::max(std::abs(a_lo), std::abs(a_hi));
    const double m_lo = a_lo <= 0 && a_hi >= 0 ? 0 : std::min(std::abs(a_lo), std::abs(a_hi));
    if (!(m_hi > 0)) return;
    // For E ≤ ilogb(v) − 2, |A| < |v|/2, so |o| > |v|/2: o's spacing is at least 2g and v's 4g,
    // so A is on g's grid: exact.
    const int lowest = std::max(m_lo > 0 ? std::ilogb(m_lo) : std::numeric_limits<int>::min(), std::ilogb(v) - 1);
    for (int E = std::ilogb(m_hi); E >= lowest; --E) {
      const double half = u * std::ldexp(1.0, E);
      if (half <= most) break;  // finer binades round by less
      const double g = std::ldexp(1.0, E + 1 - bits);
      if (o_binade >= E) {
        most = std::max(most, off_grid(g));
      } else if (o_binade != std::numeric_limits<int>::min()) {
        // o on the finer grid h: v − o is v's residue plus multiples of h, and g/2 is one of
        // them: the nearest the residues come to g/2 (half way between two of g) is v's
        // distance to h's grid.
        const double x = off_grid(std::ldexp(1.0, o_binade + 1 - bits)), d = half - x;
        most = std::max(most, (half - d) - x > 0 ? up(d) : d);  // Fast2Sum: d + that is half − x
      } else {
        most = half;
      }
    }
  };
  // Each sign of o apart, binade by binade of |o| from the largest, until they are finer than v's
  // by 4 (then A is within 2^-3|v| of v: the rest at once, as rounding at any spacing).
  const int stop = std::ilogb(v) - 4;
  for (const int sign : {1, -1}) {
    const double lo = sign > 0 ? std::max(o_lo, 0.0) : std::max(-o_hi, 0.0);
    const double hi = sign > 0 ? o_hi : -o_lo;
    if (!(hi >= lo) || hi == 0) continue;
    int e = std::ilogb(hi);
    for (; e > stop && std::ldexp(1.0, e + 1) > lo; --e) {
      if (u * std::ldexp(1.0, std::ilogb(std::ldexp(1.0, e + 1) + std::abs(v))) <= most) break;  // no larger below
      const double from = std::max(lo, std::ldexp(1.0, e)), to = std::min(hi, std::ldexp(1.0, e + 1));
      if (from <= to) over(v - sign * to, v - sign * from, e);
    }
    const double rest_hi = std::min(hi, std::ldexp(1.0, e + 1));
    if (lo < rest_hi) over(v - sign * rest_hi, v - sign * lo, std::numeric_limits<int>::min());
  }
  return most;
}
double ulp_in(Precision precision, double x) {
  const int digits = precision == Precision::f32 ? 24 : 53;
  const double smallest = precision == Precision::f32 ? 0x1p-149 : 0x1p-1074;
  if (x == 0 || !std::isfinite(x)) return smallest;
  int e;
  std::frexp(std::abs(x), &e);  // |x| = m·2^e, m in [½, 1)
  return std::max(std::ldexp(1.0, e - digits), smallest);
}

OffsetRule parse_offset_rule(std::string_view text) {
  OffsetRule r;
  r.name = std::string(text);
  auto number_after = [&](std::string_view prefix) {
    const std::string rest(text.substr(prefix.size()));
    char* end = nullptr;
    const double x = std::strtod(rest.c_str(), &end);
    if (rest.empty() || end != rest.c_str() + rest.size() || !std::isfinite(x) || !(x > 0))
      throw std::invalid_argument("offset rule '" + std::string(text) + "': " + std::string(prefix) +
                                  " needs a positive finite number");
    return x;
  };
  if (text.starts_with("fixed:")) {
    r.kind = OffsetRule::Kind::fixed;
    r.amount = number_after("fixed:");
  } else if (text.starts_with("ulps:")) {
    r.kind = OffsetRule::Kind::ulps;
    r.amount = number_after("ulps:");
    if (r.amount != std::floor(r.amount) || r.amount > 0x1p30)
      throw std::invalid_argument("offset rule '" + std::string(text) + "': ulps:N needs a whole N up to 2^30");
  } else if (text == "pbrt") {
    r.kind = OffsetRule::Kind::pbrt;
  } else if (text == "waechter-binder") {
    r.kind = OffsetRule::Kind::waechter_binder;
  } else if (text == "proved") {
    r.kind = OffsetRule::Kind::proved;
  } else {
    throw std::invalid_argument("unknown offset rule '" + std::string(text) +
                                "' (fixed:EPS, ulps:N, pbrt, waechter-binder, proved)");
  }
  return r;
}

std::vector<OffsetRule> default_offset_rules() {
  std::vector<OffsetRule> rules;
  for (std::string_view s : {"fixed:1e-4", "ulps:32", "pbrt", "waechter-binder", "proved"})
    rules.push_back(parse_offset_rule(s));
  return rules;
}

namespace {
// pbrt-v4's OffsetRayOrigin, its final step: each coordinate one more representable number away
// along n, so that the rounding of p + offset·n never pulls it back.
template <class T>
T away(T x, T n_i) {
  if (n_i > 0) return std::nextafter(x, std::numeric_limits<T>::infinity());
  if (n_i < 0) return std::nextafter(x, -std::numeric_limits<T>::infinity());
  return x;
}
template <class T>
T ulp_of(T x) {
  return T(ulp_in(std::is_same_v<T, float> ? Precision::f32 : Precision::f64, double(x)));
}
template <class T>
Vec3 apply_in(const OffsetRule& rule, const Vec3& p_in, const Vec3& n_in, double proved) {
  const T p[3] = {T(p_in.x()), T(p_in.y()), T(p_in.z())};  // p is already in T (the variant's point)
  T n[3];
  for (int i = 0; i < 3; ++i) n[i] = std::is_same_v<T, float> ? T(to_nearest_float(n_in[i])) : T(n_in[i]);
  T out[3];
  switch (rule.kind) {
    case OffsetRule::Kind::fixed:
    case OffsetRule::Kind::ulps: {
      T step;
      if (rule.kind == OffsetRule::Kind::fixed) {
        step = std::is_same_v<T, float> ? T(to_nearest_float(rule.amount)) : T(rule.amount);
      } else {
        const T m = std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2])});
        step = T(rule.amount) * ulp_of(m);
      }
      for (int i = 0; i < 3; ++i) out[i] = p[i] + step * n[i];
      break;
    }
    case OffsetRule::Kind::pbrt: {
      // pbrt-v4 Triangle::InteractionFromIntersection: pError = γ(7)·Σ|b_i·v_i| ≥ γ(7)·|p|; its
      // smallest value, γ(7)·|p| per coordinate, is what this rule spawns with.
      constexpr T u = std::numeric_limits<T>::epsilon() / 2;
      const T g7 = (7 * u) / (1 - 7 * u);
      const T d = std::abs(n[0]) * (g7 * std::abs(p[0])) + std::abs(n[1]) * (g7 * std::abs(p[1])) +
                  std::abs(n[2]) * (g7 * std::abs(p[2]));
      for (int i = 0; i < 3; ++i) out[i] = away(p[i] + d * n[i], n[i]);
      break;
    }
    case OffsetRule::Kind::proved: {
      T s = T(proved);  // the float step rounded up, never below the proved offset
      if (double(s) < proved) s = std::nextafter(s, std::numeric_limits<T>::infinity());
      for (int i = 0; i < 3; ++i) out[i] = away(p[i] + s * n[i], n[i]);
      break;
    }
    case OffsetRule::Kind::waechter_binder: {
      const Vec3 moved = std::is_same_v<T, float> ? offset_by_ulps_f32(p_in, n_in) : offset_by_ulps(p_in, n_in);
      return moved;
    }
  }
  return {double(out[0]), double(out[1]), double(out[2])};
}
}  // namespace

Vec3 apply_offset_rule(const OffsetRule& rule, Precision precision, const Vec3& p, const Vec3& n, double proved) {
  return precision == Precision::f32 ? apply_in<float>(rule, p, n, proved) : apply_in<double>(rule, p, n, proved);
}

// The displacement along the true unit normal. The renderer's n is within 2^-40 of it per
// coordinate and is rounded to the precision, so n_T·n_true ≥ 1 − u − 2^-38 (`cosine`).
//   Scaled rules (fixed, ulps): o′_i = fl(p_i + fl(s·n_i)) moves by s·n_i(1 + ε) + e_i with
//   |e_i| ≤ u·|o′_i|(1 + u): along n_true at least s·(cosine − 2u) − Σ(|n_i| + 2^-40)·u(1 + u)·|o′_i|.
//   Rounded-away rules (pbrt, proved): the step away makes each coordinate move at least
//   |fl(s·n_i)| ≥ s|n_i|(1 − u) in n_i's direction (at a binade edge too: rounding toward a power
//   of two errs by at most half the finer spacing, which the step exceeds), so along n_true at
//   least s(1 − u)(cosine − 2^-70), less what coordinates whose sign n may have wrong (|n_i| ≤
//   2^-40) take back, below 2^-37·Σ 4u·|o′_i|.
//   Wächter–Binder: per coordinate, below 1/32 a scaled step fs·n_i, else trunc(256·|n_i|)
//   representable numbers, each at least half the spacing at the coordinate's smallest magnitude.
Displacement rule_displacement(const OffsetRule& rule, Precision precision, const Bounds& points, const Vec3& n,
                               double proved) {
  const double u = unit_roundoff(precision);
  const double cosine = down(1 - up(u + 0x1p-38));
  const Vec3 qmax = largest_abs(points);
  Vec3 qmin;
  for (int i = 0; i < 3; ++i)
    qmin[i] = points.lo[i] <= 0 && points.hi[i] >= 0 ? 0.0 : std::min(std::abs(points.lo[i]), std::abs(points.hi[i]));
  auto rounding_loss = [&](double factor, double step_max) {
    double sum = 0;
    for (int i = 0; i < 3; ++i) sum = up(sum + up(up(std::abs(n[i]) + 0x1p-40) * up(factor * up(qmax[i] + step_max))));
    return sum;
  };
  auto upper = [&](double step_max) { return up(up(step_max * (1 + 4 * u)) + rounding_loss(4 * u, step_max)); };
  Displacement d;
  switch (rule.kind) {
    case OffsetRule::Kind::fixed:
    case OffsetRule::Kind::ulps: {
      double smin, smax;
      if (rule.kind == OffsetRule::Kind::fixed) {
        smin = down(rule.amount * (1 - u));
        smax = up(rule.amount * (1 + u));
      } else {
        const double mmin = std::max({qmin[0], qmin[1], qmin[2]}), mmax = std::max({qmax[0], qmax[1], qmax[2]});
        smin = rule.amount * ulp_in(precision, mmin) * (mmin == 0 ? 0 : 1);
        smax = rule.amount * ulp_in(precision, mmax) * 2;
      }
      d.min = down(down(smin * down(cosine - 2 * u)) - rounding_loss(up(u * (1 + u)), smax));
      d.max = upper(smax);
      return d;
    }
    case OffsetRule::Kind::pbrt:
    case OffsetRule::Kind::proved: {
      double smin, smax;
      if (rule.kind == OffsetRule::Kind::pbrt) {
        const double g7 = gamma_up(precision, 7), g7_lo = 7 * u;  // the renderer's γ(7), computed in T, ≥ 7u
        double lo = 0, hi = 0;
        for (int i = 0; i < 3; ++i) {
          lo += std::abs(n[i]) * qmin[i];
          hi += (std::abs(n[i]) + 0x1p-40) * qmax[i];
        }
        smin = down(down(lo * down(g7_lo * (1 - 16 * u))) * (1 - 0x1p-40));
        smax = up(up(hi * g7) * (1 + 8 * u));
      } else {
        smin = proved;  // apply_offset_rule rounds a float step up
        smax = up(up(proved) * (1 + 0x1p-20));
      }
      d.min = down(down(down(smin * (1 - u)) * down(cosine - 0x1p-70)) - rounding_loss(0x1p-35 * u, smax));
      d.max = upper(up(smax + rounding_loss(4 * u, smax)));
      return d;
    }
    case OffsetRule::Kind::waechter_binder: {
      const double origin = 1.0 / 32, fs = precision == Precision::f32 ? 1.0 / 65536 : 0x1p-16 * 0x1p-29;
      double lo = 0, hi = 0;
      for (int i = 0; i < 3; ++i) {
        const double ni = std::abs(precision == Precision::f32 ? double(to_nearest_float(n[i])) : n[i]);
        double along = INFINITY;  // the coordinate's move in n_i's direction, at least
        if (qmin[i] < origin)
          along = std::min(along, down(down(fs * ni * (1 - u)) - up(u * (1 + u) * up(origin + fs))));
        if (qmax[i] >= origin) {
          const double k = std::trunc(256 * ni);
          along = std::min(along, k * ulp_in(precision, std::max(qmin[i], origin)) / 2);
        }
        const double weight = along >= 0 ? std::max(0.0, std::abs(n[i]) - 0x1p-40) : std::abs(n[i]) + 0x1p-40;
        lo = down(lo + down(along * weight));
        hi = up(hi + up(up(256 * ulp_in(precision, qmax[i]) * 2) + fs + up(u * (qmax[i] + 1))));
      }
      d.min = lo;
      d.max = hi;
      return d;
    }
  }
  return d;
}

bool rule_proved_safe(const OffsetProof& proof, const Displacement& moved) {
  const double beyond = down(moved.min - proof.point);
  return beyond > 0 && beyond > proof.rehit_at(moved.max);  // o′ lies within point_box widened by max
}

double proved_offset(const OffsetProof& proof, Precision precision, const Vec3& n) {
  const OffsetRule rule{OffsetRule::Kind::proved, 0, "proved"};
  double s = up(proof.point + proof.rehit_at(up(2 * up(proof.point + proof.rehit_base))));
  s = s > 0 ? s : 0x1p-1000;
  for (int tries = 0; tries < 200; ++tries) {
    if (rule_proved_safe(proof, rule_displacement(rule, precision, proof.point_box, n, s))) return s;
    s = up(s * (1 + 0x1p-20) + 0x1p-1022 * tries);
    if (tries > 8) s = up(s * 2);
  }
  return INFINITY;
}

}  // namespace rayproof
