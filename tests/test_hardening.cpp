// Hostile and careless input, output paths, and interrupted or concurrent campaigns: one
// regression test per item of the hardening issue. Each test works in a directory of its own.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace {

std::string test_dir() {
  const auto* info = testing::UnitTest::GetInstance()->current_test_info();
  const std::string dir = testing::TempDir() + "/hardening-" + info->name();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

struct CliResult {
  int status;
  std::string err;
};

// Runs `rayproof ARGS` in `dir` (stdout to dir/stdout unless ARGS redirect it), stderr captured.
CliResult run(const std::string& args, const std::string& dir) {
  const std::string cmd = "cd '" + dir + "' && " + RAYPROOF_CLI + " " + args + " 2>'" + dir + "/stderr'";
  const int status = std::system(cmd.c_str());
  std::ifstream e(dir + "/stderr");
  std::stringstream ss;
  ss << e.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

std::string read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

const std::string kCase = R"({"id": "c", "ray": {"origin": [0, 0, 0], "direction": [1, 0, 0]}, )"
                          R"("shape": {"type": "sphere", "center": [5, 0, 0], "radius": 1}})";

TEST(Hardening, DeepNestingIsAnErrorNotACrash) {
  const std::string d = test_dir();
  std::string nested;
  for (int i = 0; i < 100000; ++i) nested += "{\"a\":";
  nested += "1" + std::string(100000, '}');
  std::ofstream(d + "/deep.jsonl") << kCase.substr(0, kCase.size() - 1) << ", \"found\": " << nested << "}\n"
                                   << kCase << "\n";
  for (const char* cmd : {"check", "intersect"}) {
    const CliResult r = run(std::string(cmd) + " deep.jsonl >/dev/null", d);
    EXPECT_EQ(r.status, 1) << cmd << ": " << r.err;
    EXPECT_NE(r.err.find("deep.jsonl:1: field 'found.a"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("nested deeper than 64 levels"), std::string::npos) << r.err;
  }
}

TEST(Hardening, DuplicateKeysAreRejectedByName) {
  const std::string d = test_dir();
  std::ofstream(d + "/dup.jsonl")
      << R"({"id": "a", "id": "b", "ray": {"origin": [0, 0, 0], "direction": [1, 0, 0]}, )"
         R"("shape": {"type": "sphere", "center": [5, 0, 0], "radius": 1}})"
      << "\n"
      << R"({"id": "c", "ray": {"origin": [0, 0, 0], "origin": [1, 0, 0], "direction": [1, 0, 0]}, )"
         R"("shape": {"type": "sphere", "center": [5, 0, 0], "radius": 1}})"
      << "\n";
  const CliResult r = run("check dup.jsonl >/dev/null", d);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("dup.jsonl:1: field 'id': duplicate key \"id\""), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("dup.jsonl:2: field 'ray.origin': duplicate key \"origin\""), std::string::npos) << r.err;
}

TEST(Hardening, OverflowIsReportedWhereTheNumberIs) {
  const std::string d = test_dir();
  std::ofstream(d + "/big.jsonl") << R"({"id": "1e999", "ray": {"origin": [0, 0, 1e999], "direction": [1, 0, 0]}, )"
                                     R"("shape": {"type": "sphere", "center": [5, 0, 0], "radius": 1}})"
                                  << "\n"
                                  << R"({"id": "overflow:boom", "ray": {"origin": [0, 0, 0], "direction": [1, 0, 0]}, )"
                                     R"("shape": {"type": "sphere", "center": [5, 0, -1e400], "radius": 1}})"
                                  << "\n";
  const CliResult r = run("check big.jsonl >/dev/null", d);
  EXPECT_NE(r.err.find("big.jsonl:1: field 'ray.origin[2]': value 1e999 overflows the double range"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("big.jsonl:2: field 'shape.center[2]': value -1e400 overflows the double range"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("boom overflows"), std::string::npos) << r.err;
}

TEST(Hardening, ControlCharactersAreEscapedInMessages) {
  const std::string d = test_dir();
  std::ofstream(d + "/esc.jsonl")
      << R"({"id": "x\u001b[2J", "ray": {"origin": [0, 0, 0], "direction": [1, 0, 0]}, )"
         R"("shape": {"type": "sphere", "center": [5, 0, 0], "radius": 1, "\u001b[31m": 1}})"
      << "\n";
  const CliResult r = run("check esc.jsonl >/dev/null", d);
  EXPECT_EQ(r.err.find('\x1b'), std::string::npos);
  EXPECT_NE(r.err.find("\\x1b[31m"), std::string::npos) << r.err;
}

TEST(Hardening, OutputsNeverFollowPlantedLinksNorReplaceDevicesOrInputs) {
  const std::string d = test_dir();
  std::ofstream(d + "/cases.jsonl") << kCase << "\n";
  // A symlink planted where the old code put its fixed temporary must stay untouched.
  std::ofstream(d + "/victim") << "precious\n";
  ASSERT_EQ(::symlink((d + "/victim").c_str(), (d + "/out.jsonl.tmp").c_str()), 0);
  EXPECT_EQ(run("check cases.jsonl -o out.jsonl", d).status, 0);
  EXPECT_EQ(read(d + "/victim"), "precious\n");
  EXPECT_NE(read(d + "/out.jsonl").find("\"id\":\"c\""), std::string::npos);
  // A FIFO is written in place and stays a FIFO.
  ASSERT_EQ(::mkfifo((d + "/fifo").c_str(), 0600), 0);
  std::thread reader([&] { std::ofstream(d + "/captured") << read(d + "/fifo"); });
  EXPECT_EQ(run("check cases.jsonl -o fifo", d).status, 0);
  reader.join();
  struct stat st {};
  ASSERT_EQ(::stat((d + "/fifo").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_NE(read(d + "/captured").find("\"id\":\"c\""), std::string::npos);
  // An output that is an input is refused, and the input survives.
  const CliResult same = run("check cases.jsonl -o cases.jsonl", d);
  EXPECT_EQ(same.status, 2);
  EXPECT_NE(same.err.find("is also an input"), std::string::npos) << same.err;
  EXPECT_EQ(run("check cases.jsonl --summary cases.jsonl", d).status, 2);
  EXPECT_EQ(read(d + "/cases.jsonl"), kCase + "\n");
  // No temporaries are left behind.
  for (const auto& e : std::filesystem::directory_iterator(d))
    EXPECT_NE(e.path().filename().string().rfind(".out.jsonl.", 0), 0u) << e.path();
}

TEST(Hardening, AnOutputThatCannotBeWrittenFailsBeforeTheWork) {
  const std::string d = test_dir();
  const auto start = std::chrono::steady_clock::now();
  const CliResult trade = run("trade --count 100000 -o missing/dir/trade.csv", d);
  EXPECT_EQ(trade.status, 2);
  EXPECT_NE(trade.err.find("missing/dir/trade.csv"), std::string::npos) << trade.err;
  const CliResult render =
      run(std::string("render ") + RAYPROOF_SCENES_DIR + "/seed2-diffuse.json -o missing/x.png", d);
  EXPECT_EQ(render.status, 2);
  const CliResult fuzz = run("fuzz --count 100000 --summary missing/s.json -o f.jsonl", d);
  EXPECT_EQ(fuzz.status, 2);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
}

TEST(Hardening, WriteErrorsOnStandardOutputFail) {
  const std::string d = test_dir();
  std::ofstream(d + "/cases.jsonl") << kCase << "\n";
  for (const char* cmd : {"variants", "intersect cases.jsonl", "check cases.jsonl"}) {
    const CliResult r = run(std::string(cmd) + " > /dev/full", d);
    EXPECT_EQ(r.status, 2) << cmd;
    EXPECT_NE(r.err.find("standard output: write failed"), std::string::npos) << cmd << ": " << r.err;
  }
}

TEST(Hardening, SmallThingsACarelessUserHits) {
  const std::string d = test_dir();
  std::ofstream(d + "/cases.jsonl") << kCase << "\n";
  EXPECT_EQ(run("check - < cases.jsonl > out.jsonl", d).status, 0);
  EXPECT_NE(read(d + "/out.jsonl").find("\"id\":\"c\""), std::string::npos);
  CliResult r = run("check nope.jsonl", d);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("nope.jsonl: cannot open: No such file or directory"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(":0:"), std::string::npos);
  r = run("check .", d);
  EXPECT_NE(r.err.find("is a directory"), std::string::npos) << r.err;
  EXPECT_EQ(run("check cases.jsonl --variants ,", d).status, 2);
  r = run("fuzz --seed -1 -o f.jsonl", d);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--seed"), std::string::npos);
  EXPECT_EQ(run("fuzz --count 1e3 --families random --shapes box -o f.jsonl", d).status, 0);
  r = run("fuzz --count 1.5 -o f.jsonl", d);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("whole number"), std::string::npos) << r.err;
  // Seconds: "nan" passes a range check (no comparison with NaN fails), so it is named here.
  for (const std::string option : {"--checkpoint-every", "--case-timeout"})
    for (const std::string bad : {"nan", "inf", "-1", "1e9", "x"}) {
      r = run("fuzz --count 10 --families random --shapes box -o f.jsonl " + option + " " + bad, d);
      EXPECT_EQ(r.status, 2) << option << " " << bad;
      EXPECT_NE(r.err.find(option + ": expected seconds"), std::string::npos) << r.err;
    }
  EXPECT_EQ(run("render nothing.json -o x.png", d).status, 2);
  EXPECT_EQ(run("no-such-command", d).status, 2);
}

TEST(Hardening, EnterOnlyFindingsReplayGreen) {
  const std::string d = test_dir();
  ASSERT_EQ(run("fuzz --rule enter-only --count 1000 --max-findings 50 -o f.jsonl", d).status, 0);
  ASSERT_FALSE(read(d + "/f.jsonl").empty());
  const CliResult r = run("check f.jsonl -o /dev/null", d);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find(" 0 expectations contradicted"), std::string::npos) << r.err;
}

TEST(Hardening, AStaleCheckpointNeverTurnsFindingsIntoZeros) {
  const std::string d = test_dir();
  const std::string campaign = "fuzz --families tangent --shapes sphere --count 6000 --batch 1000 ";
  ASSERT_EQ(run(campaign + "--keep-checkpoint -o f.jsonl", d).status, 0);
  const std::string complete = read(d + "/f.jsonl");
  // A fresh run over the same output, killed after its first batch: the old checkpoint is
  // superseded first, so --resume continues the new run, not the old one.
  EXPECT_EQ(run(campaign + "--crash-after-batches 0 -o f.jsonl", d).status, 3);
  const CliResult resumed = run(campaign + "--resume -o f.jsonl", d);
  EXPECT_EQ(resumed.status, 0) << resumed.err;
  EXPECT_EQ(read(d + "/f.jsonl").find('\0'), std::string::npos);
  EXPECT_EQ(read(d + "/f.jsonl"), complete);
}

TEST(Hardening, ResumeRefusesAFileThatIsNotTheCheckpointsOwn) {
  const std::string d = test_dir();
  const std::string campaign =
      "fuzz --families tangent --shapes sphere --count 6000 --batch 1000 --checkpoint-every 0 ";
  ASSERT_EQ(run(campaign + "--crash-after-batches 3 -o f.jsonl", d).status, 3);
  const std::string written = read(d + "/f.jsonl");
  ASSERT_GT(written.size(), 10u);
  // Shorter than the checkpoint says.
  std::filesystem::resize_file(d + "/f.jsonl", written.size() / 2);
  CliResult r = run(campaign + "--resume -o f.jsonl", d);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("shorter than"), std::string::npos) << r.err;
  // Same length, other bytes.
  std::string altered = written;
  altered[0] = altered[0] == '{' ? '[' : '{';
  std::ofstream(d + "/f.jsonl", std::ios::binary) << altered;
  r = run(campaign + "--resume -o f.jsonl", d);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("are not the findings"), std::string::npos) << r.err;
  // The file as written resumes.
  std::ofstream(d + "/f.jsonl", std::ios::binary) << written;
  EXPECT_EQ(run(campaign + "--resume -o f.jsonl", d).status, 0);
}

TEST(Hardening, TwoCampaignsOnOneOutputAreRefused) {
  const std::string d = test_dir();
  // The first campaign runs in the background (stopping by itself after 60 s at the latest, and
  // holding none of the test's output pipes); $! is its own pid, not a subshell's.
  const std::string first = std::string("cd '") + d + "'; timeout 60 " + RAYPROOF_CLI +
                            " fuzz --families grazing --shapes triangle --count 40000000 --threads 1 -o f.jsonl"
                            " </dev/null >/dev/null 2>&1 & echo $! > '" +
                            d + "/pid'";
  ASSERT_EQ(std::system(first.c_str()), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const CliResult second = run("fuzz --families random --shapes sphere --count 100 -o f.jsonl", d);
  std::system(("kill $(cat '" + d + "/pid') 2>/dev/null").c_str());
  EXPECT_EQ(second.status, 2);
  EXPECT_NE(second.err.find("another rayproof campaign is writing it"), std::string::npos) << second.err;
}

}  // namespace
