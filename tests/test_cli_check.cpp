// `rayproof check` end to end: the result lines field for field, the summary, and the exit code.
#include <gtest/gtest.h>
#include <unistd.h>

#include "cli_run.h"
#include "test_dir.h"
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "rayproof/core/json_fields.h"

namespace rayproof {
namespace {

using testing_support::CliRun;
CliRun run(const std::string& args) { return testing_support::run_cli(args); }

std::string write(const std::string& name, const std::string& text) {
  const std::string path = rayproof::testing_support::test_dir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

const char* kTangent =
    R"({"id": "tangent-unit", "ray": {"origin": [-2, 1, 0], "direction": [1, 0, 0]}, )"
    R"("shape": {"type": "sphere", "center": [0, 0, 0], "radius": 1}, "expect": {"class": "tangent", "t": 2}})";

TEST(CheckCli, ResultLineFollowsTheSpecFieldForField) {
  const std::string path = write("tangent.jsonl", std::string(kTangent) + "\n");
  const CliRun r = run("check " + path + " --variants textbook,stable --summary " +
                       rayproof::testing_support::test_dir() + "/sum.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json line = json::parse(r.out);
  EXPECT_EQ(line["id"], "tangent-unit");
  EXPECT_EQ(line["exact"], (json{{"class", "tangent"}, {"t", "0x1p+1"}}));
  ASSERT_EQ(line["variants"].size(), 2u);
  for (const char* v : {"textbook", "stable"}) {
    const json& o = line["variants"][v];
    EXPECT_EQ(o.size(), 4u);
    EXPECT_TRUE(o.contains("class") && o.contains("t") && o.contains("ulp") && o.contains("agrees"));
    EXPECT_EQ(o["agrees"], o["class"] == "tangent");
  }
  std::ifstream s(rayproof::testing_support::test_dir() + "/sum.json");
  const json summary = json::parse(s);
  EXPECT_EQ(summary["cases"], 1);
  EXPECT_EQ(summary["variants"]["stable"]["cases"], 1);
  // The table on stderr fits a screen and adds up: agree + wrong + n/t = cases (issue 41).
  std::istringstream lines(r.err);
  int rows = 0;
  for (std::string l; std::getline(lines, l);) {
    std::istringstream w(l);
    std::string name, shape, cases, agree, wrong, cannot_tell;
    if (!(w >> name >> shape >> cases >> agree >> wrong >> cannot_tell) || (name != "textbook" && name != "stable"))
      continue;
    EXPECT_LE(l.size(), 120u) << l;
    EXPECT_EQ(std::stoul(agree) + std::stoul(wrong) + std::stoul(cannot_tell), std::stoul(cases)) << l;
    ++rows;
  }
  EXPECT_EQ(rows, 2) << r.err;
}

TEST(CheckCli, APlainAnswerToATangentIsCountedAsCannotTell) {
  // The ray lies in the plane z = 0 of the triangle and enters it at t = 1: exactly a tangent
  // (worked by hand). Möller–Trumbore's determinant is 0 and it says miss: "cannot tell", not
  // "wrong". A sphere whose textbook discriminant cancels (exact enter, textbook tangent) is
  // "wrong": tangent is no plain answer.
  const std::string path =
      write("cannot-tell.jsonl", R"({"id": "coplanar", "ray": {"origin": [-1, 1, 0], "direction": [1, 0, 0]}, )"
                                 R"("shape": {"type": "triangle", "vertices": [[0, 0, 0], [4, 0, 0], [0, 4, 0]]}})"
                                 "\n"
                                 R"({"id": "far", "ray": {"origin": [0, 0, 0], "direction": [1, 0, 0]}, )"
                                 R"("shape": {"type": "sphere", "center": [134217728, 0, 0], "radius": 1}})"
                                 "\n");
  const std::string summary = rayproof::testing_support::test_dir() + "/cannot-tell.json";
  const CliRun r = run("check " + path + " --variants moller-trumbore,textbook --summary " + summary);
  ASSERT_EQ(r.status, 0) << r.err;
  std::ifstream in(summary);
  const json s = json::parse(in);
  EXPECT_EQ(s["variants"]["moller-trumbore"]["cannot_tell"], 1);
  EXPECT_EQ(s["variants"]["moller-trumbore"]["wrong"], 0);
  EXPECT_EQ(s["variants"]["moller-trumbore"]["disagreements"]["tangent->miss"], 1);
  EXPECT_EQ(s["variants"]["textbook"]["wrong"], 1);
  EXPECT_EQ(s["variants"]["textbook"]["cannot_tell"], 0);
  EXPECT_EQ(s["variants"]["textbook"]["disagreements"]["enter->tangent"], 1);
}

TEST(CheckCli, WrongExpectationFailsWithFileAndLine) {
  const std::string path = write(
      "wrong.jsonl",
      std::string(kTangent) + "\n" +
          R"({"id": "liar", "ray": {"origin": [-2, 1, 0], "direction": [1, 0, 0]}, )"
          R"("shape": {"type": "sphere", "center": [0, 0, 0], "radius": 1}, "expect": {"class": "enter", "t": 2}})"
          "\n");
  const CliRun r = run("check " + path);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("wrong.jsonl:2: case 'liar'"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 2);  // both lines still reported
  const std::string t_path =
      write("wrong-t.jsonl", R"({"id": "t-off", "ray": {"origin": [-2, 1, 0], "direction": [1, 0, 0]}, )"
                             R"("shape": {"type": "sphere", "center": [0, 0, 0], "radius": 1}, )"
                             R"("expect": {"class": "tangent", "t": "0x1.0000000000001p+1"}})"
                             "\n");
  EXPECT_EQ(run("check " + t_path).status, 1);
}

TEST(CheckCli, BadLinesAreReportedAndTheRestChecked) {
  const std::string path = write("bad.jsonl", std::string(kTangent) + "\n{\"id\": \"x\"\n");
  const CliRun r = run("check " + path + " -o " + rayproof::testing_support::test_dir() + "/check-out.jsonl");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("bad.jsonl:2:"), std::string::npos) << r.err;
  std::ifstream out(rayproof::testing_support::test_dir() + "/check-out.jsonl");
  std::string first;
  std::getline(out, first);
  EXPECT_EQ(json::parse(first)["id"], "tangent-unit");
  EXPECT_NE(run("check " + write("empty2.jsonl", "")).status, 0);
}

}  // namespace
}  // namespace rayproof
