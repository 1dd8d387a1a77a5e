// The registry of compiled kernels: what a build with fewer elements or variants
// (cmake -DMUSCLE_ELEMENTS=..., -DMUSCLE_VARIANTS=...) says when a run asks for
// one it left out.
// The lists themselves: tests/materials/test_compile_forms.py.
#include <common/errors.h>
#include <forms/form_registry.h>

#include <gtest/gtest.h>
#include <string>

using namespace muscle;

TEST(ElementsOfTheBuild, CompiledElementsNeedNoAdvice)
{
  const std::string compiled = forms::compiled_elements();
  for (const auto& [cell, degree] : {std::pair<std::string, int>{"hexahedron", 1},
                                     {"hexahedron", 2}, {"tetrahedron", 1}, {"tetrahedron", 2}})
  {
    const std::string name = cell.substr(0, 3) + std::to_string(degree);
    const bool in_build = ("," + compiled + ",").find("," + name + ",") != std::string::npos;
    EXPECT_EQ(forms::element_not_compiled(cell, degree).empty(), in_build) << name;
  }
}

TEST(ElementsOfTheBuild, LeftOutElementIsNamedWithTheRemedy)
{
  const std::string advice = forms::element_not_compiled("hexahedron", 3);
  EXPECT_NE(advice.find("not hex3"), std::string::npos) << advice;
  EXPECT_NE(advice.find(forms::compiled_elements()), std::string::npos) << advice;
  EXPECT_NE(advice.find("MUSCLE_ELEMENTS=all"), std::string::npos) << advice;
  try
  {
    forms::find_fe_variant("combi", "hexahedron", 3);
    FAIL() << "expected an input error";
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("not hex3"), std::string::npos) << e.what();
  }
}

TEST(ElementsOfTheBuild, LeftOutVariantNamesTheFilter)
{
  if (!*forms::compiled_variants())
    GTEST_SKIP() << "this build compiles every variant";
  // a filtered build (tools/muscle run's) leaves out BLE's F-bar element
  try
  {
    forms::find_fe_variant("ble", "hexahedron", 1, -1, -1, true);
    FAIL() << "expected an input error";
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("MUSCLE_VARIANTS"), std::string::npos) << e.what();
  }
}
