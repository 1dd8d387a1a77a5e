// Scene files: YAML -> Scene, with every mistake reported as
// "FILE:LINE: KEY: what is wrong; what is allowed".  The sections are read
// in a fixed order, so that of two mistakes the same one is always reported.
#include "scene/scene.h"
#include "scene/scene_sections.h"

#include "common/errors.h"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace muscle
{
namespace
{
using scene_input::Entry;

YAML::Node load_yaml(const std::string& text, const std::string& name)
{
  try
  {
    return YAML::Load(text);
  }
  catch (const YAML::Exception& e)
  {
    throw InputError(name + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
}

// What a checkpoint must match: the sections that shape the physics as
// written, the mesh by its resolved path (a copy of the scene elsewhere still
// matches), and the parameter values (parameter files included) and data
// files' contents of the parts.
std::string physics_of_sections(YAML::Node& root)
{
  std::string physics;
  for (const char* k : {"element", "parts", "boundary", "loads", "tie", "contact", "dynamics"})
    physics += std::string(k) + ":\n" + YAML::Dump(root[k]) + "\n";
  return physics;
}

std::string physics_of_mesh(const MeshSpec& mesh)
{
  std::string physics = "mesh: " + mesh.path + "\n";
  for (const auto& [k, v] : mesh.numbers)
    physics += k + "=" + std::to_string(v) + "\n";
  return physics;
}

std::string physics_of_parts(const std::vector<Part>& parts)
{
  std::string physics;
  for (const Part& part : parts)
  {
    physics += part.parameters.to_text();
    for (const std::string& path : {part.fibres.path, part.activation_scale.path})
      if (!path.empty())
      {
        std::stringstream data;
        data << std::ifstream(path).rdbuf();
        physics += path + ":" + std::to_string(std::hash<std::string>{}(data.str())) + "\n";
      }
  }
  return physics;
}

void check_top(const Entry& top)
{
  if (!top.is_map())
    top.fail("a scene is a mapping with keys title, mesh, element, parts, boundary, time, "
             "solver, output; found " + top.shown());
  top.require_map(
      {"title", "mesh", "element", "parts", "boundary", "time", "dynamics", "solver", "output",
       "loads", "tie", "contact"});
}
} // namespace

Scene parse_scene(const std::string& text, const std::string& name,
                  const std::string& directory, const std::vector<std::string>& overrides)
{
  YAML::Node root = load_yaml(text, name);
  Scene scene;
  scene.file = name;
  scene.text = text;
  scene.overrides = overrides;
  scene_input::Source source{name, {}};
  if (!overrides.empty() and !root.IsMap())
    throw InputError(name + ": a scene is a mapping; --set needs one");
  for (const std::string& assignment : overrides)
    scene_input::apply_override(root, assignment, source);
  const Entry top(root, "", source, 1);
  check_top(top);
  scene.title = top["title"].text(std::filesystem::path(name).stem().string());
  scene.physics += physics_of_sections(root);

  using namespace scene_input;
  read_mesh(top, directory, scene.mesh);
  scene.physics += physics_of_mesh(scene.mesh);
  read_element(top, scene.mesh);
  read_parts(top, directory, scene);
  read_boundary(top, scene);
  read_loads(top, scene);
  read_ties(top, scene);
  read_contacts(top, scene);
  check_uniform_axial(scene);
  read_time(top, scene.time);
  read_dynamics(top, scene);
  read_solver(top, scene);
  scene.physics += physics_of_parts(scene.parts);
  read_output(top, scene.output);
  return scene;
}

Scene read_scene(const std::string& path, const std::vector<std::string>& overrides)
{
  std::ifstream in(path);
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error) or !in)
    throw InputError(path + ": scene file not found");
  std::stringstream text;
  text << in.rdbuf();
  const std::string directory
      = std::filesystem::absolute(path).parent_path().string();
  return parse_scene(text.str(), path, directory, overrides);
}

} // namespace muscle
