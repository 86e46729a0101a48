// SPDX-License-Identifier: Apache-2.0
// A stage's parameter table against a small settings struct: one line binds a field to its name,
// default, range and description; the spec, the reader and the report entry all come from it.
#include "core/stages/param_table.h"

#include <gtest/gtest.h>

namespace scanprep {
namespace {

enum class Method { kFirst, kSecond };

struct ToySettings {
  Method method = Method::kFirst;
  float weight = 0;
  int rounds = 0;
  Derived<double> radius;
  double unbound = -1;  // in the struct, not in the table
};

const ParamTable<ToySettings>& ToyParams() {
  using S = ToySettings;
  static const ParamTable<S> table = {
      param::Choice(&S::method, "toy.method", {"first", "second"}, "which way"),
      param::Real(&S::weight, "toy.weight", 0.3, Closed(0, 1), "a weight"),
      param::Integer(&S::rounds, "toy.rounds", 4, Closed(1, 10), "rounds of the second way")
          .When([](const S& s) { return s.method == Method::kSecond; }),
      param::DerivedReal(&S::radius, "toy.radius_mm", "from the data", LeftOpen(0, 100),
                         "a radius"),
  };
  return table;
}

TEST(ParamTable, SpecsComeFromTheLines) {
  const std::vector<ParamSpec> specs = ToyParams().Specs();
  ASSERT_EQ(specs.size(), 4u);
  EXPECT_EQ(specs[0].name, "toy.method");
  EXPECT_EQ(specs[0].kind, ParamKind::kChoice);
  EXPECT_EQ(specs[0].choices, (std::vector<std::string>{"first", "second"}));
  EXPECT_EQ(specs[1].kind, ParamKind::kReal);
  EXPECT_EQ(specs[1].default_value, 0.3);
  EXPECT_EQ(specs[1].range.ToString(), "[0, 1]");
  EXPECT_EQ(specs[2].kind, ParamKind::kInteger);
  EXPECT_EQ(specs[2].default_text, "4");
  EXPECT_FALSE(specs[3].default_value.has_value());
  EXPECT_EQ(specs[3].default_text, "from the data");
}

TEST(ParamTable, ReadGivesDefaultsOrOverridesAndLeavesUnboundFieldsAlone) {
  const ToySettings defaults = ToyParams().Read({});
  EXPECT_EQ(defaults.method, Method::kFirst);
  EXPECT_EQ(defaults.weight, 0.3f);
  EXPECT_EQ(defaults.rounds, 4);
  EXPECT_FALSE(defaults.radius.forced.has_value());
  EXPECT_EQ(defaults.radius.name, "toy.radius_mm");
  EXPECT_EQ(defaults.radius.Or(7), 7);
  EXPECT_EQ(defaults.unbound, -1);

  const ToySettings set = ToyParams().Read({{"toy.method", "second"},
                                            {"toy.weight", "0.75"},
                                            {"toy.rounds", "9"},
                                            {"toy.radius_mm", "2.5"}});
  EXPECT_EQ(set.method, Method::kSecond);
  EXPECT_EQ(set.weight, 0.75f);
  EXPECT_EQ(set.rounds, 9);
  EXPECT_EQ(set.radius.Or(7), 2.5);
}

// The report holds the value as the request wrote it (the double, not the float field's), each
// choice as its text, only the lines that apply, and no derived one (the stage records that).
TEST(ParamTable, RecordReportsWhatAppliesAsTheRequestWroteIt) {
  const ParamOverrides overrides = {{"toy.weight", "0.1"}, {"toy.radius_mm", "2.5"}};
  StageReport first;
  ToyParams().Record(overrides, ToyParams().Read(overrides), first);
  EXPECT_EQ(first.parameters, (std::map<std::string, double>{{"toy.weight", 0.1}}));
  EXPECT_EQ(first.text_parameters, (std::map<std::string, std::string>{{"toy.method", "first"}}));

  ParamOverrides second = overrides;
  second["toy.method"] = "second";
  StageReport report;
  ToyParams().Record(second, ToyParams().Read(second), report);
  EXPECT_EQ(report.parameters,
            (std::map<std::string, double>{{"toy.weight", 0.1}, {"toy.rounds", 4}}));
  EXPECT_EQ(report.text_parameters.at("toy.method"), "second");

  // An internal stage that uses some of them records just those.
  StageReport some;
  ToyParams().Record(second, ToyParams().Read(second), some, {"toy.rounds"});
  EXPECT_EQ(some.parameters, (std::map<std::string, double>{{"toy.rounds", 4}}));
  EXPECT_TRUE(some.text_parameters.empty());
}

// Code outside the stage names a parameter by its field: a preset writes an override, a bound
// names another parameter. A field the table does not bind is a programming error, caught by
// the first test that runs the caller.
TEST(ParamTable, NameAndOverrideFindALineByItsField) {
  EXPECT_EQ(ToyParams().Name(&ToySettings::rounds), "toy.rounds");
  EXPECT_EQ(ToyParams().Override(&ToySettings::method, Method::kSecond),
            (std::pair<const std::string, std::string>{"toy.method", "second"}));
  EXPECT_EQ(ToyParams().Override(&ToySettings::weight, 0.5f),
            (std::pair<const std::string, std::string>{"toy.weight", "0.5"}));
  EXPECT_DEATH(ToyParams().Name(&ToySettings::unbound), "");
}

}  // namespace
}  // namespace scanprep
