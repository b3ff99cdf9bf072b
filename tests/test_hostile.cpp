// Hostile input, round 3 (issue 26), through the command line: each test is one reproduction
// from the issue that crashed, hung, lost results or lied before, and must now end in a clear
// error or a correct result. Meshes, cameras and the BVH are in test_meshes.cpp and
// test_scene_render.cpp; merge's checks in test_fuzz.cpp.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "rayproof/core/json_fields.h"
#include "cli_run.h"
#include "test_dir.h"

namespace rayproof {
namespace {

using testing_support::CliRun;
using testing_support::test_dir;
CliRun run(const std::string& args) { return testing_support::run_cli(args); }

std::string write(const std::string& name, const std::string& text) {
  const std::string path = test_dir() + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

std::string read(const std::string& path) {
  std::stringstream s;
  s << std::ifstream(path, std::ios::binary).rdbuf();
  return s.str();
}

std::vector<json> lines_of(const std::string& text) {
  std::vector<json> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(json::parse(line));
  return out;
}

std::string sphere_cases(int n) {
  std::string out;
  for (int i = 0; i < n; ++i)
    out += R"({"id": "c)" + std::to_string(i) + R"(", "ray": {"origin": [-3, )" + std::to_string(0.01 * i) +
           R"(, 0], "direction": [1, 0, 0]}, "shape": {"type": "sphere", "center": [0, 0, 0], "radius": 1}})" + "\n";
  return out;
}

std::string bad_plugin(const std::string& kind) { return std::string(BAD_PLUGIN_DIR) + "/libtest_bad_" + kind + ".so"; }

// Item 7: a plugin's load-time code runs in a worker, never in rayproof.
TEST(HostilePlugins, LoadTimeCodeIsThePluginsNotRayproofs) {
  const std::string cases = write("cases.jsonl", sphere_cases(2));
  // exit(0) in rayproof_plugin(): an error naming how the loading ended, exit code 2.
  CliRun r = run("check " + cases + " --plugin " + bad_plugin("EXIT_AT_LOAD"));
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("ended the worker process (exited with status 0)"), std::string::npos) << r.err;
  // printf in rayproof_plugin(): nothing of it on check's standard output.
  r = run("check " + cases + " --plugin " + bad_plugin("PRINT_AT_LOAD"));
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.out.find("not-a-result"), std::string::npos) << r.out;
  // A source with ESC sequences and a newline: listed escaped, on one line.
  r = run("variants --plugin " + bad_plugin("ESC_SOURCE"));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos);
  EXPECT_NE(r.out.find("esc-source\tsphere\tdouble\t\\x1b[2J\\x1b]0;owned\\x07line\\x0abreak"), std::string::npos)
      << r.out;
  // A 10 MB name: refused by its length in a short line.
  r = run("variants --plugin " + bad_plugin("HUGE_NAME"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("at most 64 bytes"), std::string::npos) << r.err.substr(0, 300);
  EXPECT_LT(r.err.size(), 1000u);
}

// Item 6: a plugin that forks on every call: reported as a plugin error, its answers not judged,
// and nothing it forked is left running.
TEST(HostilePlugins, AForkingPluginIsAPluginErrorAndNothingIsJudged) {
  const std::string cases = write("cases.jsonl", sphere_cases(40));
  const CliRun r = run("check " + cases + " --plugin " + bad_plugin("FORKING") +
                       " --variants stable,forking --summary " + test_dir() + "/s.json");
  const auto lines = lines_of(r.out);
  ASSERT_EQ(lines.size(), 40u) << r.err;
  EXPECT_EQ(lines[0]["variants"]["forking"]["error"], "protocol error") << lines[0].dump();
  for (const json& l : lines) {
    EXPECT_FALSE(l["variants"]["forking"].contains("agrees")) << "a forking plugin's answer was judged: " << l.dump();
    EXPECT_TRUE(l["variants"]["stable"].contains("class"));  // the others go on
  }
  EXPECT_NE(r.err.find("the plugin forked"), std::string::npos) << r.err;
}

// Item 5, plugins: a worker whose response pipe closes while it runs on is not waited for.
TEST(HostilePlugins, AWorkerThatClosesItsPipeAndRunsOnIsNotWaitedFor) {
  std::string cases = R"({"id": "closes", "ray": {"origin": [-30, 0, 0], "direction": [1, 0, 0]}, )"
                      R"("shape": {"type": "sphere", "center": [0, 0, 0], "radius": 23}})";
  cases = write("cases.jsonl", cases + "\n" + sphere_cases(1));
  const auto start = std::chrono::steady_clock::now();
  const CliRun r =
      run("check " + cases + " --plugin " + MISBEHAVING_PLUGIN + " --variants test-crashing,stable --case-timeout 60");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 30) << "rayproof waited on a worker that closed its pipe";
  EXPECT_NE(r.err.find("closed its response pipe and kept running (killed)"), std::string::npos) << r.err;
  const auto lines = lines_of(r.out);
  ASSERT_EQ(lines.size(), 2u) << r.err;
  EXPECT_EQ(lines[0]["variants"]["test-crashing"]["error"], "crash") << lines[0].dump();
  EXPECT_TRUE(lines[1]["variants"]["stable"].contains("class"));
}

// Item 5: every wait is bounded by --case-timeout (or less), the reason says what happened, and
// the command's process group is ended with it.
TEST(HostileExec, EveryWaitIsBoundedAndTheCommandsGroupEnds) {
  const std::string cases = write("cases.jsonl", sphere_cases(3));
  struct Bad {
    std::string command, message;
  };
  const std::vector<Bad> bad = {
      {"exec 1>&-; sleep 41.25", "closed its standard output and kept running (killed)"},
      // Closing its input races rayproof's first write: an EPIPE, or the case waits in the pipe.
      {"exec 0<&-; sleep 41.25", "stopped reading its input and kept running (killed)|no answer within"},
      {"yes | tr -d '\\\\n'", "an answer line longer than 1048576 bytes"},
      {"sleep 41.25 & exit 0", "exited early (status 0)"},
      {"read l; sleep 41.25 & exit 3", "exited early (status 3)"}};
  for (const Bad& b : bad) {
    const auto start = std::chrono::steady_clock::now();
    const CliRun r = run("check " + cases + " --variants stable --case-timeout 1 --exec \"x=" + b.command + "\"");
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, 30) << b.command << " held rayproof past every timeout";
    const std::size_t bar = b.message.find('|');
    const bool said = r.err.find(b.message.substr(0, bar)) != std::string::npos ||
                      (bar != std::string::npos && r.err.find(b.message.substr(bar + 1)) != std::string::npos);
    EXPECT_TRUE(said) << b.command << ": " << r.err;
    EXPECT_EQ(lines_of(r.out).size(), 3u) << b.command;
  }
  // Nothing the commands started is left: their process groups were killed.
  FILE* p = popen("pgrep -f 'sleep 41[.]25' | wc -l", "r");
  char buf[32] = {};
  fgets(buf, sizeof buf, p);
  pclose(p);
  EXPECT_EQ(std::atoi(buf), 0) << "orphans of the exec commands still run";
}

// Item 4: an unreadable exec answer (200+ bytes of multibyte text, a raw \xff id) costs that
// command, never the campaign's findings, summary or the other variants.
TEST(HostileExec, AnUnreadableAnswerCostsOnlyItsCommand) {
  const std::string long_line =
      write("long.sh", "while read l; do printf 'x%0300d\\n' 0 | sed 's/0/\\xc3\\xa9/g'; done\n");
  const std::string raw_id =
      write("rawid.sh", "while read l; do printf '{\"id\": \"\\377\", \"class\": \"miss\"}\\n'; done\n");
  for (const std::string& script : {long_line, raw_id}) {
    const std::string out = test_dir() + "/f.jsonl", summary = test_dir() + "/s.json";
    const CliRun r = run("fuzz --shapes sphere --families tangent --count 300 --variants stable,bad --exec 'bad=sh " +
                         script + "' --no-shrink -o " + out + " --summary " + summary);
    EXPECT_EQ(r.status, 0) << r.err;
    const json s = json::parse(read(summary));
    EXPECT_EQ(s["cases"]["tangent\tsphere"], 300) << s.dump();
    EXPECT_GT(lines_of(read(out)).size(), 0u) << "stable's findings were lost";
  }
  // A scene path that is not UTF-8: audit.json still written, the name escaped.
  const std::string scene = test_dir() + "/s\xff.json";
  std::ofstream(scene) << R"({"camera": {"eye": [0,0,-5], "look_at": [0,0,0], "up": [0,1,0], "fov_deg": 40, "width": 8,
      "height": 8}, "objects": [{"type": "sphere", "center": [0,0,0], "radius": 1}]})";
  const CliRun r = run("audit '" + scene + "' --variants stable -o " + test_dir() + "/audit");
  EXPECT_EQ(r.status, 0) << r.err;
  const json a = json::parse(read(test_dir() + "/audit/audit.json"));
  EXPECT_NE(a["scene"].get<std::string>().find("s\\xff.json"), std::string::npos) << a["scene"];
  // An exec variant that stops mid-audit: the others' results are written, and it is never
  // called exact for the scene (its later pixels were not judged).
  const CliRun stopped =
      run("audit '" + scene + "' --variants stable,bad --exec 'bad=sh " + long_line + "' -o " + test_dir() + "/audit2");
  const json b = json::parse(read(test_dir() + "/audit2/audit.json"));
  ASSERT_EQ(b["variants"].size(), 2u) << stopped.err;
  for (const json& v : b["variants"]) {
    if (v["name"] == "bad") {
      EXPECT_EQ(v["exact_for_scene"], false) << v.dump();
      EXPECT_TRUE(v.contains("stopped")) << v.dump();
      EXPECT_TRUE(v["ns_per_ray"].is_null()) << "a stopped variant answered nothing: no cost " << v.dump();
    } else {
      EXPECT_EQ(v["exact_for_scene"], true) << v.dump();
    }
  }
}

// Item 9: an exec variant named like built-in stable's diff image gets files of its own.
TEST(HostileAudit, VariantFilesNeverCollide) {
  const std::string scene = write("scene.json", R"({"camera": {"eye": [0,0,-5], "look_at": [0,0,0], "up": [0,1,0],
      "fov_deg": 40, "width": 8, "height": 8}, "objects": [{"type": "sphere", "center": [0,0,0], "radius": 1}]})");
  const std::string script = std::string(RAYPROOF_SOURCE_DIR) + "/examples/exec/textbook_sphere.py";
  const std::string dir = test_dir() + "/audit";
  const CliRun r = run("audit " + scene + " --variants stable,stable-diff --exec stable-diff=" + script + " -o " + dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const json a = json::parse(read(dir + "/audit.json"));
  std::set<std::string> files;
  for (const json& v : a["variants"]) {
    EXPECT_TRUE(files.insert(v["render"].get<std::string>()).second) << v.dump();
    EXPECT_TRUE(files.insert(v["diff"].get<std::string>()).second) << v.dump();
    EXPECT_FALSE(read(dir + "/" + v["render"].get<std::string>()).empty());
  }
  EXPECT_EQ(files.size(), 4u);
  // Issue 25, item 12: the report's reproduce line is the command, with the variants and the exec.
  const std::string html = read(dir + "/report.html");
  EXPECT_NE(html.find("--variants stable,stable-diff --exec stable-diff=" + script), std::string::npos)
      << html.substr(html.find("Reproduce"), 300);
}

// Item 10: shard numbers are never wrapped to 32 bits, negative indices name their variable.
TEST(HostileFuzz, ShardsAreWholeNumbersOrAnErrorNamingTheirSource) {
  const std::string out = test_dir() + "/x.jsonl";
  CliRun r = run("fuzz --count 10 --shard 4294967296/4294967297 -o " + out);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("out of range"), std::string::npos) << r.err;
  r = run("fuzz --count 10 --shard 1/-4 -o " + out);
  EXPECT_EQ(r.status, 2);
  const std::string env = "SLURM_ARRAY_TASK_ID=-1 SLURM_ARRAY_TASK_COUNT=4 ";
  const std::string cmd = env + RAYPROOF_CLI + std::string(" fuzz --count 10 --shard auto -o ") + out + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string text;
  char buf[512];
  while (size_t n = fread(buf, 1, sizeof buf, p)) text.append(buf, n);
  const int status = pclose(p);
  EXPECT_EQ(WEXITSTATUS(status), 2) << text;
  EXPECT_NE(text.find("SLURM_ARRAY_TASK_ID is not a whole number"), std::string::npos) << text;
}

// Item 11: an audit beyond the machine's memory is refused with the estimate, before any work.
TEST(HostileInputs, AnAuditBeyondMemoryIsRefusedWithItsEstimate) {
  const std::string scene = write("huge.json", R"({"camera": {"eye": [0,0,-5], "look_at": [0,0,0], "up": [0,1,0],
      "fov_deg": 40, "width": 16384, "height": 16384}, "samples": 1024,
      "objects": [{"type": "sphere", "center": [0,0,0], "radius": 1}]})");
  const CliRun r = run("audit " + scene + " --variants stable -o " + test_dir() + "/huge");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("needs about"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("GB available"), std::string::npos) << r.err;
}

// Item 11: `render -` reads the scene from standard input; an answers file's precision line may
// follow blank lines.
TEST(HostileInputs, DashIsStandardInputAndThePrecisionLineMayFollowBlankLines) {
  const std::string png = test_dir() + "/stdin.png";
  const CliRun r = run("render - -o " + png + " < " + std::string(RAYPROOF_SOURCE_DIR) + "/scenes/seed1-sphere.json");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(read(png).empty());
  const std::string cases = write("cases.jsonl", sphere_cases(1));
  const std::string answers =
      write("answers.jsonl", "\n  \n{\"precision\": \"float\"}\n{\"id\": \"c0\", \"class\": \"enter\", \"t\": 2}\n");
  const CliRun c = run("check " + cases + " --answers mine=" + answers + " --variants stable");
  EXPECT_EQ(c.err.find("unknown key"), std::string::npos) << c.err;
  const auto lines = lines_of(c.out);
  ASSERT_EQ(lines.size(), 1u) << c.err;
  EXPECT_TRUE(lines[0]["variants"]["mine"].contains("ulp_own")) << lines[0].dump();
}

}  // namespace
}  // namespace rayproof
