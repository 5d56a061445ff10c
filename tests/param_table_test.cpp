// denoisers/param_table.hpp: a parameter is declared once (name, field, default, range,
// meaning) and both the schema and the settings come from that one line. These tests show the
// bindings of every built-in table are sound and that the self-check catches a binding slip.
#include "denoisers/param_table.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "denoisers/asvgf.hpp"
#include "denoisers/common/atrous.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/common/poisson_blur.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/hybrid.hpp"
#include "denoisers/reblur.hpp"
#include "denoisers/reengine.hpp"
#include "denoisers/svgf.hpp"
#include "denoisers/variants.hpp"

namespace arena {
namespace {

template <class Settings>
std::string problemsOf(const ParamTable<Settings>& table) {
  std::string out;
  for (const std::string& p : table.selfCheck()) out += "\n  " + p;
  return out;
}

// Each parameter reaches its own field and no other, and each field holds its default: for the
// tables with a header here, and for every registered variant through schema(), which runs the
// same check (eaw, temporal and slgf keep their tables in their .cpp).
TEST(ParamTable, EveryBuiltInTableBindsEachParameterToItsOwnField) {
  EXPECT_EQ(problemsOf(reprojectionParams()), "");
  EXPECT_EQ(problemsOf(footprintParams()), "");
  EXPECT_EQ(problemsOf(atrousKernelParams()), "");
  EXPECT_EQ(problemsOf(hitDistanceParams()), "");
  EXPECT_EQ(problemsOf(surfaceWeightParams()), "");
  EXPECT_EQ(problemsOf(svgfParams()), "");
  EXPECT_EQ(problemsOf(asvgfParams()), "");
  EXPECT_EQ(problemsOf(reblurParams()), "");
  EXPECT_EQ(problemsOf(hybridParams()), "");
  EXPECT_EQ(problemsOf(reEngineParams()), "");
  EXPECT_NO_THROW(builtinDenoisers());
}

// The settings are the table's: its defaults, and any override, land in the named field.
TEST(ParamTable, SettingsComeFromTheTable) {
  const SvgfSettings d = svgfParams().defaults();
  EXPECT_EQ(d.iterations, 5);
  EXPECT_EQ(d.feedbackTap, 1);
  EXPECT_FLOAT_EQ(d.alpha, 0.2f);
  EXPECT_EQ(d.maxHistory, 32.0f);
  EXPECT_EQ(d.youngColor, YoungColor::Accumulated);
  EXPECT_EQ(d.atrous.kernel, AtrousKernel::B3Spline5x5);
  EXPECT_EQ(d.atrous.edges.sigmaL, 4.0f);
  EXPECT_EQ(d.atrous.edges.normalForm, NormalWeightForm::CosinePower);  // fixed, not a parameter
  EXPECT_EQ(d.reprojection.depthThreshold, 10.0f);
  EXPECT_EQ(d.footprint.policy, FootprintPolicy::Scaled);

  const ParamSchema schema = svgfParams().schema();
  const SvgfSettings s = svgfParams().settings(schema.resolve({{"youngColor", "spatial"},
                                                               {"kernel", "3x3"},
                                                               {"sigmaL", "2.5"},
                                                               {"normalThreshold", "8"},
                                                               {"footprint", "native"}},
                                                              "svgf"),
                                               "svgf");
  EXPECT_EQ(s.youngColor, YoungColor::Spatial);
  EXPECT_EQ(s.atrous.kernel, AtrousKernel::Compact3x3);
  EXPECT_EQ(s.atrous.edges.sigmaL, 2.5f);
  EXPECT_EQ(s.reprojection.normalThreshold, 8.0f);
  EXPECT_EQ(s.footprint.policy, FootprintPolicy::Native);

  const ReblurSettings r = reblurParams().settings(
      reblurParams().schema().resolve(
          {{"hitPoint", "false"}, {"historyFixShape", "ours"}, {"hitDistance", "mirror"}},
          "reblur"),
      "reblur");
  EXPECT_FALSE(r.hitPoint);
  EXPECT_EQ(r.historyFixShape, HistoryFixShape::Ours);
  EXPECT_EQ(r.hitDistanceChannel, "specHitDistMirror");
}

// Cross-parameter rules keep their messages, naming the variant that includes the table.
TEST(ParamTable, CrossParameterChecksNameTheOwner) {
  for (const std::string owner : {"svgf", "asvgf"}) {
    const ParamSchema schema = owner == "svgf" ? svgfParams().schema() : asvgfParams().schema();
    const ParamSet params = schema.resolve({{"feedbackTap", "6"}}, owner);
    try {
      if (owner == "svgf")
        svgfParams().settings(params, owner);
      else
        asvgfParams().settings(params, owner);
      ADD_FAILURE() << owner << " accepted feedbackTap > iterations";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()),
                owner + ".feedbackTap=6 exceeds " + owner +
                    ".iterations=5; use a feedbackTap in [0, iterations] (0 = no spatial "
                    "feedback)");
    }
  }
}

// A-SVGF reuses SVGF's alpha and adds what it means there; nothing else of it is restated.
TEST(ParamTable, IncludedParametersKeepTheirDeclaration) {
  const ParamSchema svgfSchema = svgfParams().schema(), asvgfSchema = asvgfParams().schema();
  const ParamSpec* svgf = svgfSchema.find("alpha");
  const ParamSpec* asvgf = asvgfSchema.find("alpha");
  ASSERT_TRUE(svgf && asvgf);
  EXPECT_EQ(asvgf->meaning.rfind(svgf->meaning, 0), 0u);
  EXPECT_NE(asvgf->meaning, svgf->meaning);
  EXPECT_EQ(asvgf->defaultValue, svgf->defaultValue);
}

// The self-check can fail: two names on one field, a fixed setting that overrides a parameter, a
// name declared twice.
struct Toy {
  float a, b;
  bool on;
};

TEST(ParamTable, SelfCheckCatchesBindingSlips) {
  const auto twoNamesOneField = ParamTable<Toy>()
                                    .real("a", &Toy::a, 1, 0, 10, "a")
                                    .real("b", &Toy::a, 2, 0, 10, "b (bound to a by mistake)");
  EXPECT_FALSE(twoNamesOneField.selfCheck().empty());
  EXPECT_THROW(twoNamesOneField.schema(), Error);

  const auto fixedOverridesParameter =
      ParamTable<Toy>().boolean("on", &Toy::on, true, "on").fixed([](Toy& t) { t.on = true; });
  EXPECT_FALSE(fixedOverridesParameter.selfCheck().empty());

  const auto twice =
      ParamTable<Toy>().real("a", &Toy::a, 1, 0, 10, "a").real("a", &Toy::b, 1, 0, 10, "a again");
  EXPECT_FALSE(twice.selfCheck().empty());

  const auto sound = ParamTable<Toy>()
                         .real("a", &Toy::a, 1, 0, 10, "a")
                         .real("b", &Toy::b, 2, 0, 10, "b")
                         .boolean("on", &Toy::on, false, "on");
  EXPECT_TRUE(sound.selfCheck().empty());
  EXPECT_EQ(sound.defaults().b, 2.0f);
}

// A declaration that is wrong in itself is named, before anything is resolved from it: a default
// outside its range (every run would use what --param refuses), an inverted range, a name a label
// could not hold, no meaning, a name declared as two types (which read one value as the other).
struct ToyInt {
  int radius;
  float sigma;
};

TEST(ParamTable, SelfCheckNamesADeclarationWrongInItself) {
  const auto problemOf = [](const auto& table) {
    const std::vector<std::string> problems = table.selfCheck();
    return problems.empty() ? std::string("none") : problems.front();
  };
  EXPECT_EQ(problemOf(ParamTable<ToyInt>().integer("radius", &ToyInt::radius, 9, 1, 8, "r")),
            "'radius': its default 9 lies outside its range [1, 8]");
  EXPECT_EQ(problemOf(ParamTable<ToyInt>().real("sigma", &ToyInt::sigma, 4, 8, 0, "s")),
            "'sigma': its range [8, 0] is inverted (min > max)");
  // An unbounded range lets a run pass a value the filter cannot use (1e39 read as a float: inf).
  EXPECT_NE(problemOf(ParamTable<ToyInt>().real("sigma", &ToyInt::sigma, 4, 0,
                                                std::numeric_limits<double>::infinity(), "s"))
                .find("'sigma': its range [0, inf] is not finite"),
            std::string::npos);
  // A float member's value beyond a float's range is refused, not read as an infinity.
  ParamSchema wide = ParamTable<ToyInt>().real("sigma", &ToyInt::sigma, 4, 0, 1e300, "s").schema();
  wide.readsFloatsAsFloat();  // as the registry makes every built-in's
  try {
    wide.resolve({{"sigma", "1e39"}}, "toy");
    ADD_FAILURE() << "1e39 read as a float";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("a number within a float's range"), std::string::npos)
        << e.what();
  }
  // ...and one too small for a float, not read as a 0 nobody wrote; a float's smallest is kept.
  try {
    wide.resolve({{"sigma", "1e-300"}}, "toy");
    ADD_FAILURE() << "1e-300 read as 0";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("0 or a number at least about 1.4e-45 in magnitude"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(wide.resolve({{"sigma", "1.5e-45"}}, "toy"));
  EXPECT_NO_THROW(wide.resolve({{"sigma", "0"}}, "toy"));
  EXPECT_EQ(problemOf(ParamTable<ToyInt>().integer("the radius", &ToyInt::radius, 2, 1, 8, "r")),
            "'the radius': a name must be non-empty without '=', ',', '[', ']' or spaces");
  EXPECT_EQ(problemOf(ParamTable<ToyInt>().integer("", &ToyInt::radius, 2, 1, 8, "r")),
            "'': a name must be non-empty without '=', ',', '[', ']' or spaces");
  EXPECT_EQ(problemOf(ParamTable<ToyInt>().integer("radius", &ToyInt::radius, 2, 1, 8, "")),
            "'radius': no meaning (arena denoisers lists it)");
  EXPECT_EQ(problemOf(ParamTable<ToyInt>()
                          .integer("radius", &ToyInt::radius, 2, 1, 8, "r")
                          .real("radius", &ToyInt::sigma, 2, 1, 8, "r as a real")),
            "'radius' is declared twice");
  EXPECT_THROW(ParamTable<ToyInt>().integer("radius", &ToyInt::radius, 9, 1, 8, "r").schema(),
               Error);
  EXPECT_EQ(problemOf(ParamTable<ToyInt>().integer("radius", &ToyInt::radius, 8, 1, 8, "r")),
            "none");
  EXPECT_EQ(ParamSpec::choice("mode", "wide", {"narrow", "scaled"}, "m").problem(),
            "'mode': its default is not one of its choices");
  EXPECT_EQ(ParamSpec::choice("mode", "scaled", {"narrow", "scaled"}, "m").problem(), "");
}

// A bound field with an initialiser of its own is a second default: a caller that builds the
// struct by hand gets it, the table never shows it. The self-check names the parameter.
struct ToyWithDefault {
  float a = 3.0f;
  float b{};
};

TEST(ParamTable, SelfCheckRefusesABoundFieldWithItsOwnInitialiser) {
  const auto hidden = ParamTable<ToyWithDefault>()
                          .real("a", &ToyWithDefault::a, 3, 0, 10, "a (the struct says 3 too)")
                          .real("b", &ToyWithDefault::b, 2, 0, 10, "b");
  const std::vector<std::string> problems = hidden.selfCheck();
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("'a': its field declares an initialiser"), std::string::npos)
      << problems[0];
  EXPECT_THROW(hidden.schema(), Error);
  // An unbound field may keep its initialiser: it is a constant, declared once in the struct.
  const auto constant = ParamTable<ToyWithDefault>().real("b", &ToyWithDefault::b, 2, 0, 10, "b");
  EXPECT_TRUE(constant.selfCheck().empty());
  EXPECT_EQ(constant.defaults().a, 3.0f);
}

// The shared blocks' parameters: reblur and reengine read the same surface-weight table, and
// reengine's low-resolution upsampling takes its plane and normal tests from it.
TEST(ParamTable, SharedBlocksAreDeclaredOnceAndReachEveryVariant) {
  const SurfaceWeightSettings w = surfaceWeightParams().defaults();
  const ReblurSettings reblur = reblurParams().defaults();
  const ReEngineSettings reengine = reEngineParams().defaults();
  for (const SurfaceWeightSettings& v :
       {reblur.weights, reengine.weights, reengine.upsample.weights}) {
    EXPECT_EQ(v.planeSigma, w.planeSigma);
    EXPECT_EQ(v.normalPower, w.normalPower);
    EXPECT_EQ(v.minHitWeight, w.minHitWeight);
  }
  EXPECT_EQ(w.planeSigma, 0.02f);
  const ParamSchema schema = reEngineParams().schema();
  const ReEngineSettings changed =
      reEngineParams().settings(schema.resolve({{"planeSigma", "0.05"}}, "reengine"), "reengine");
  EXPECT_EQ(changed.weights.planeSigma, 0.05f);
  EXPECT_EQ(changed.upsample.weights.planeSigma, 0.05f);
}

}  // namespace
}  // namespace arena
