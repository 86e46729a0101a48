// SPDX-License-Identifier: Apache-2.0
// Each parameter's name is written once outside the tests: in its line of its stage's parameter
// table (core/stages/param_table.h), which the spec, the reader and the report come from. A
// second copy of the text is a second place to change when the name changes, and a reader whose
// copy is misspelt only fails when it runs. The source is scanned as C++ string literals,
// comments left out; the one copy must stand in a `param::` line of a stage's table.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/stages/stage.h"

namespace scanprep {
namespace {

namespace fs = std::filesystem;

// The contents of the string literals in C++ source `text`, each with the code of its statement
// before it (from the last ';', '{' or '}'); comments and character literals are skipped.
std::vector<std::pair<std::string, std::string>> StringLiterals(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> literals;
  std::string statement;
  size_t i = 0;
  while (i < text.size()) {
    if (text.compare(i, 2, "//") == 0) {
      i = text.find('\n', i);
    } else if (text.compare(i, 2, "/*") == 0) {
      i = text.find("*/", i + 2);
      if (i != std::string::npos) i += 2;
    } else if (text[i] == '"' || text[i] == '\'') {
      const char quote = text[i];
      std::string literal;
      for (++i; i < text.size() && text[i] != quote; ++i) {
        if (text[i] == '\\') ++i;  // an escaped character, quotes included
        if (i < text.size()) literal += text[i];
      }
      if (quote == '"') literals.emplace_back(std::move(literal), statement);
      ++i;
    } else {
      if (text[i] == ';' || text[i] == '{' || text[i] == '}') statement.clear();
      statement += text[i];
      ++i;
    }
  }
  return literals;
}

// Per name in `names`: the files under root/dirs (C++ sources and headers) that hold it as a
// literal, one entry per occurrence, as "file" or, where the statement around the literal
// (from the last ';', '{' or '}' before it) declares a table line, "file param::".
std::map<std::string, std::vector<std::string>> Occurrences(const fs::path& root,
                                                            const std::vector<std::string>& dirs,
                                                            const std::set<std::string>& names) {
  std::map<std::string, std::vector<std::string>> found;
  for (const std::string& dir : dirs) {
    for (const auto& entry : fs::recursive_directory_iterator(root / dir)) {
      const std::string ext = entry.path().extension().string();
      if (!entry.is_regular_file() || (ext != ".cc" && ext != ".h")) continue;
      std::ifstream in(entry.path());
      std::stringstream text;
      text << in.rdbuf();
      for (const auto& [literal, statement] : StringLiterals(text.str())) {
        if (!names.contains(literal)) continue;
        std::string where = fs::relative(entry.path(), root).string();
        if (statement.find("param::") != std::string::npos) where += " param::";
        found[literal].push_back(where);
      }
    }
  }
  for (auto& [name, files] : found) std::sort(files.begin(), files.end());
  return found;
}

// The checkout this file was compiled from: tests/core/stages/ is three folders below it.
fs::path SourceRoot() {
  return fs::path(__FILE__).parent_path().parent_path().parent_path().parent_path();
}

TEST(ParamNamesTest, EveryRegisteredNameIsWrittenOnceOutsideTheTests) {
  const fs::path root = SourceRoot();
  ASSERT_TRUE(fs::exists(root / "core/stages/params.h")) << root;
  std::set<std::string> names;
  for (const ParamSpec& spec : AllParamSpecs()) names.insert(spec.name);
  ASSERT_GE(names.size(), 40u);  // every stage's, not an empty registry
  const auto found = Occurrences(root, {"core", "server", "client", "proto"}, names);
  for (const std::string& name : names) {
    const auto it = found.find(name);
    const size_t count = it == found.end() ? 0 : it->second.size();
    std::string where;
    for (size_t k = 0; count > 0 && k < count; ++k) where += " " + it->second[k];
    // None would be a name the registry builds at run time, out of reach of this check.
    EXPECT_EQ(count, 1u) << '"' << name << "\" is written " << count << " times:" << where;
    if (count == 1) {
      EXPECT_TRUE(it->second[0].starts_with("core/stages/") && it->second[0].ends_with(" param::"))
          << '"' << name << "\" is written outside a stage's parameter table:" << where;
    }
  }
}

// The control: a synthetic tree where one name is written twice (once more in a comment and
// once as a longer literal, neither of which counts) and another once.
TEST(ParamNamesTest, TheScanCountsLiteralsNotCommentsOrLongerText) {
  const fs::path root = fs::path(testing::TempDir()) / "param_names_control";
  fs::remove_all(root);
  fs::create_directories(root / "src" / "inner");
  std::ofstream(root / "src" / "a.cc") << "// \"stage.twice\" in a comment\n"
                                          "auto a = Read(\"stage.twice\");\n"
                                          "/* \"stage.once\" */ auto b = \"stage.twice.not\";\n"
                                          "char q = '\"'; auto c = \"say \\\"stage.once\\\"\";\n";
  std::ofstream(root / "src" / "inner" / "b.h")
      << "constexpr auto kA = \"stage.twice\";\n"
         "static const ParamTable<S> table = {param::Real(&S::x, \"stage.once\", 1)};\n";
  std::ofstream(root / "src" / "notes.md") << "\"stage.once\"\n";
  const auto found = Occurrences(root, {"src"}, {"stage.twice", "stage.once", "stage.never"});
  EXPECT_EQ(found.at("stage.twice"), (std::vector<std::string>{"src/a.cc", "src/inner/b.h"}));
  EXPECT_EQ(found.at("stage.once"), (std::vector<std::string>{"src/inner/b.h param::"}));
  EXPECT_FALSE(found.contains("stage.never"));
}

}  // namespace
}  // namespace scanprep
