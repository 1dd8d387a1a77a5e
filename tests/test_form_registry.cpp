// The registry of compiled kernels: what a build with fewer elements or variants
// (cmake -DMUSCLE_ELEMENTS=..., -DMUSCLE_VARIANTS=...) says when a run asks for
// one it left out.
// The lists themselves: tests/materials/test_compile_forms.py.  Also what the law
// files declare and C++ looks up by name: defaults and omega kernels.
#include <common/errors.h>
#include <forms/form_registry.h>
#include <material/material_point.h>

#include <gtest/gtest.h>
#include <set>
#include <stdexcept>
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

// ---------------------------------------------- what the law files declare --
// Defaults (DEFAULT_FOR) and omega kernels (omega_kernel(...)) are named in the law
// files only; the configure step checks them (tests/materials/test_compile_forms.py).

TEST(LawDefaults, EachRoleOfOneLawHasExactlyOne)
{
  for (const std::string role : {"muscle", "fit"})
  {
    int holders = 0;
    for (const forms::LawInfo& law : forms::laws())
      for (const char* r : law.default_for)
        holders += role == r;
    EXPECT_EQ(holders, 1) << "laws declaring DEFAULT_FOR \"" << role << "\"";
    EXPECT_EQ(models_for(role).size(), 1u) << role;
    EXPECT_EQ(default_model(role), models_for(role).front()) << role;
  }
}

TEST(LawDefaults, TodaysDefaults)
{
  // a scene part without a material and fusiform: COMBI; a fit result before the fit: BLE
  EXPECT_EQ(default_model("muscle").name(), "combi");
  EXPECT_EQ(default_model("fit").name(), "ble");
  std::vector<std::string> paper;
  for (const Model& m : models_for("paper"))
    paper.push_back(m.name());
  EXPECT_EQ(paper, (std::vector<std::string>{"ble", "combi", "giant", "wkm"}))
      << "the paper's models (loadcases --model all): " << join(paper);
}

TEST(LawDefaults, UnknownRoleIsALogicError)
{
  EXPECT_TRUE(models_for("no such role").empty());
  try
  {
    default_model("no such role");
    FAIL() << "expected a logic error";
  }
  catch (const std::logic_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("no such role"), std::string::npos) << e.what();
  }
}

TEST(OmegaKernels, TheCppRegistryIsWhatTheBuildRead)
{
  // compile_forms.py read the names from activation_kernels.cpp's MUSCLE_OMEGA_KERNEL
  // lines; the C++ registry is filled by the same lines
  std::set<std::string> read, registered;
  for (const char* name : forms::registered_omega_kernels())
    read.insert(name);
  for (const auto& [name, kernel] : omega_kernels())
  {
    registered.insert(name);
    EXPECT_NE(kernel, nullptr) << name;
  }
  EXPECT_EQ(read, registered);
  EXPECT_TRUE(registered.count("wkm") and registered.count("giant"));
}

TEST(OmegaKernels, EveryLawFindsItsKernel)
{
  for (const Model& model : all_models())
    if (model.has_activation_kernel())
    {
      EXPECT_NE(omega_kernel_of(model), nullptr) << model.name();
      const OmegaTaylor w = activation_kernel(model, 1.0, 10.0,
                                              ehret_parameters(ParameterSet(model)));
      EXPECT_TRUE(w.ok) << model.name();
      EXPECT_GT(w.value, 0.0) << model.name() << ": omega_a at fibre stretch 1, level 10";
    }
    else
      EXPECT_STREQ(model.law().omega_kernel, "") << model.name();
}

TEST(OmegaKernels, UnregisteredKernelNamesTheRegisteredOnes)
{
  try
  {
    find_omega_kernel("hill", "law mine (mine.py)");
    FAIL() << "expected an input error";
  }
  catch (const InputError& e)
  {
    const std::string what = e.what();
    for (const std::string word : {"law mine (mine.py)", "'hill'", "giant", "wkm",
                                   "activation_kernels.cpp"})
      EXPECT_NE(what.find(word), std::string::npos) << word << " in: " << what;
  }
}
