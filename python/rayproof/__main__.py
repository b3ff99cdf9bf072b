"""python3 -m rayproof: where the module is and what it has (a check that the install works)."""
import os

import rayproof

print(f"rayproof module at {os.path.dirname(rayproof.__file__)}: {len(rayproof.variants())} variants and tracers; "
      f"tracer families {', '.join(rayproof.TRACER_FAMILIES)}")
