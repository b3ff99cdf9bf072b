// One flag vocabulary for every command: --variants/--shapes/--families (lists, `all`), their
// old singular spellings as aliases, and render's one variant per shape.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

// A directory of this test's own (ctest runs tests in parallel processes).
std::string test_dir() {
  const auto* info = testing::UnitTest::GetInstance()->current_test_info();
  const std::string dir = testing::TempDir() + "/flags-" + info->test_suite_name() + "-" + info->name();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

int run(const std::string& args, const std::string& dir) {
  const std::string cmd = std::string(RAYPROOF_CLI) + " " + args + " >'" + dir + "/stdout' 2>'" + dir + "/stderr'";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A negative count is an error naming the flag, not 2^64 − 1 findings (issue 25's new flag too).
TEST(Flags, CountsRefuseNegativeNumbers) {
  const std::string dir = test_dir();
  for (const char* flag : {"--max-shrunk", "--max-findings"}) {
    EXPECT_EQ(run(std::string("fuzz --count 10 ") + flag + " -1 -o '" + dir + "/x.jsonl'", dir), 2) << flag;
    EXPECT_NE(read(dir + "/stderr").find(std::string(flag) + ": expected a whole number >= 0, got '-1'"),
              std::string::npos)
        << read(dir + "/stderr");
  }
}

TEST(Flags, SingularSpellingsAreAliasesOfTheLists) {
  const std::string d = test_dir();
  ASSERT_EQ(
      run("fuzz --family tangent,grazing --shape sphere --count 600 --seed 4 --threads 1 -o '" + d + "/a.jsonl'", d),
      0);
  ASSERT_EQ(run("fuzz --families tangent --families grazing --shapes sphere --count 600 --seed 4 --threads 2 -o '" + d +
                    "/b.jsonl'",
                d),
            0);
  const std::string a = read(d + "/a.jsonl");
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(a, read(d + "/b.jsonl"));
  const std::string cases = std::string(RAYPROOF_SCENES_DIR) + "/cases/sphere.jsonl";
  ASSERT_EQ(run("check '" + cases + "' --variant stable -o '" + d + "/c1.jsonl'", d), 0);
  ASSERT_EQ(run("check '" + cases + "' --variants stable -o '" + d + "/c2.jsonl'", d), 0);
  EXPECT_EQ(read(d + "/c1.jsonl"), read(d + "/c2.jsonl"));
  EXPECT_EQ(read(d + "/c1.jsonl").find("textbook"), std::string::npos);
}

TEST(Flags, AllMeansEveryOneAnywhereInTheList) {
  const std::string d = test_dir();
  const std::string cases = std::string(RAYPROOF_SCENES_DIR) + "/cases/box.jsonl";
  ASSERT_EQ(run("check '" + cases + "' -o '" + d + "/default.jsonl'", d), 0);
  ASSERT_EQ(run("check '" + cases + "' --variants slab,all -o '" + d + "/all.jsonl'", d), 0);
  EXPECT_EQ(read(d + "/default.jsonl"), read(d + "/all.jsonl"));
  // --shapes narrows --variants: no box variant is left for sphere only.
  ASSERT_EQ(run("check '" + cases + "' --shapes sphere -o '" + d + "/none.jsonl'", d), 0);
  EXPECT_EQ(read(d + "/none.jsonl").find("robust-slab"), std::string::npos);
  EXPECT_NE(run("check '" + cases + "' --variants nope", d), 0);
  EXPECT_NE(read(d + "/stderr").find("unknown variant 'nope'"), std::string::npos);
  EXPECT_NE(run("fuzz --families nope -o '" + d + "/x.jsonl'", d), 0);
  EXPECT_NE(run("fuzz --shapes cube -o '" + d + "/x.jsonl'", d), 0);
}

TEST(Flags, FuzzJudgesTheNamedVariantsAndLeavesTheOraclesOwnOutByDefault) {
  const std::string d = test_dir();
  ASSERT_EQ(
      run("fuzz --families tangent,extremes --shapes sphere --count 2000 --format json -o '" + d + "/a.jsonl'", d), 0);
  const std::string table = read(d + "/stderr");
  EXPECT_NE(table.find("\"textbook\""), std::string::npos);
  EXPECT_EQ(table.find("certified-sphere"), std::string::npos);
  ASSERT_EQ(run("fuzz --families tangent,extremes --shapes sphere --variants certified-sphere,textbook --count 2000 "
                "--summary '" +
                    d + "/s.json' -o '" + d + "/b.jsonl'",
                d),
            0);
  std::ifstream in(d + "/s.json");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string summary = ss.str();
  EXPECT_NE(summary.find("\"tangent\\tcertified-sphere\""), std::string::npos);
  EXPECT_EQ(summary.find("stable-fma"), std::string::npos);
  // The certified variant is the oracle's front end: on the hardest families it never disagrees.
  for (const char* family : {"tangent", "extremes"}) {
    const std::string key = std::string("\"") + family + "\\tcertified-sphere\": {";
    const size_t at = summary.find(key);
    ASSERT_NE(at, std::string::npos) << family;
    const size_t agree = summary.find("\"agree\": ", at), cases = summary.find("\"cases\": ", at);
    EXPECT_EQ(std::stoul(summary.substr(agree + 9)), std::stoul(summary.substr(cases + 9))) << family;
  }
}

TEST(Flags, TradeAndStabilityTakeTheSameFlags) {
  const std::string d = test_dir();
  ASSERT_EQ(run("trade --variants stable --shapes sphere --families random --count 300 -o '" + d + "/t.csv'", d), 0);
  const std::string csv = read(d + "/t.csv");
  EXPECT_NE(csv.find("\nstable,sphere,random,300,"), std::string::npos) << csv;
  EXPECT_EQ(csv.find("textbook"), std::string::npos);
  ASSERT_EQ(run("stability --shapes sphere,box --variants textbook,slab --from -20 --to 20 --step 20 --count 5 -o '" +
                    d + "/s'",
                d),
            0);
  EXPECT_TRUE(std::filesystem::exists(d + "/s/sphere/textbook.svg"));
  EXPECT_TRUE(std::filesystem::exists(d + "/s/box/slab.svg"));
  EXPECT_FALSE(std::filesystem::exists(d + "/s/sphere/stable.svg"));
  EXPECT_NE(run("stability --shapes sphere --variants slab -o '" + d + "/s2'", d), 0);
}

TEST(Flags, RenderTakesOneVariantPerShape) {
  const std::string d = test_dir();
  const std::string scene = std::string(RAYPROOF_SCENES_DIR) + "/seed1-sphere.json";
  EXPECT_EQ(run("render '" + scene + "' --variants textbook,watertight -o '" + d + "/a.png'", d), 0);
  EXPECT_TRUE(std::filesystem::exists(d + "/a.png"));
  EXPECT_NE(run("render '" + scene + "' --variants textbook,stable -o '" + d + "/b.png'", d), 0);
  EXPECT_NE(read(d + "/stderr").find("two sphere variants"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(d + "/b.png"));
}

}  // namespace

namespace {

// check --rule enter-only: an origin inside a sphere exits, which the rule does not count.
TEST(Flags, CheckUnderTheEnterOnlyRule) {
  const std::string d = test_dir();
  std::ofstream(d + "/inside.jsonl") << R"({"id": "inside", "ray": {"origin": [0, 0, 0], "direction": [1, 0, 0]}, )"
                                        R"("shape": {"type": "sphere", "center": [0, 0, 0], "radius": 2}})"
                                     << "\n"
                                     << R"({"id": "outside", "ray": {"origin": [-5, 0, 0], "direction": [1, 0, 0]}, )"
                                        R"("shape": {"type": "sphere", "center": [0, 0, 0], "radius": 2}})"
                                     << "\n";
  ASSERT_EQ(run("check '" + d + "/inside.jsonl' --rule enter-only --variants stable -o '" + d + "/eo.jsonl'", d), 0);
  ASSERT_EQ(run("check '" + d + "/inside.jsonl' --variants stable -o '" + d + "/n.jsonl'", d), 0);
  const std::string eo = read(d + "/eo.jsonl"), n = read(d + "/n.jsonl");
  EXPECT_NE(eo.find(R"({"id":"inside","exact":{"class":"miss","t":null})"), std::string::npos) << eo;
  EXPECT_NE(n.find(R"({"id":"inside","exact":{"class":"exit","t":"0x1p+1"})"), std::string::npos) << n;
  EXPECT_NE(eo.find(R"({"id":"outside","exact":{"class":"enter","t":"0x1.8p+1"})"), std::string::npos) << eo;
}

}  // namespace
