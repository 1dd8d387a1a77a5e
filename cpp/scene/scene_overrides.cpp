// `--set KEY=VALUE`: edits of the scene's YAML tree before it is read, so
// that a replaced value is checked like one from the file.
#include "scene/scene_yaml.h"

#include "common/errors.h"

namespace muscle::scene_input
{
namespace
{
/// One step of a dotted scene path: a key, or an index into a list.
struct PathStep
{
  std::string key;
  long index = -1;
};

/// "parts[0].material.parameters.kappa" -> parts, [0], material, parameters, kappa
std::vector<PathStep> split_path(const std::string& path, const std::string& origin)
{
  std::vector<PathStep> steps;
  std::size_t i = 0;
  auto bad = [&](const std::string& what) -> InputError
  { return InputError(origin + ": " + what + "; a key is a dotted path such as "
                      "parts[0].material.parameters.kappa or time.step"); };
  while (i < path.size())
  {
    const std::size_t end = path.find_first_of(".[", i);
    const std::string key = path.substr(i, end == std::string::npos ? end : end - i);
    if (key.empty())
      throw bad("empty name in '" + path + "'");
    steps.push_back({key});
    i = end == std::string::npos ? path.size() : end;
    while (i < path.size() and path[i] == '[')
    {
      const std::size_t close = path.find(']', i);
      const std::string digits
          = path.substr(i + 1, close == std::string::npos ? close : close - i - 1);
      if (close == std::string::npos or digits.empty()
          or digits.find_first_not_of("0123456789") != std::string::npos or digits.size() > 6)
        throw bad("'" + path.substr(i) + "' is not a list index [N]");
      steps.push_back({"", std::stol(digits)});
      i = close + 1;
    }
    if (i < path.size())
    {
      if (path[i] != '.' or i + 1 == path.size())
        throw bad("unexpected '" + path.substr(i) + "'");
      ++i;
    }
  }
  if (steps.empty())
    throw bad("no key");
  return steps;
}

/// KEY=VALUE taken apart, the value parsed as YAML.
struct Assignment
{
  std::string origin; ///< "--set KEY=VALUE", for messages
  std::string path;
  std::vector<PathStep> steps;
  YAML::Node value;
};

Assignment parse_assignment(const std::string& assignment)
{
  Assignment a;
  a.origin = "--set " + assignment;
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos)
    throw InputError(a.origin + ": expected KEY=VALUE, e.g. time.step=0.01");
  a.path = assignment.substr(0, eq);
  a.steps = split_path(a.path, a.origin);
  try
  {
    a.value = YAML::Load(assignment.substr(eq + 1));
  }
  catch (const YAML::Exception& e)
  {
    throw InputError(a.origin + ": the value is not valid YAML: " + e.msg);
  }
  if (!a.value.IsDefined() or a.value.IsNull())
    throw InputError(a.origin + ": no value after '='");
  return a;
}

/// Step k, an index: into that item of the list `node`, or set it if last.
void descend_item(YAML::Node& node, const Assignment& a, std::size_t k,
                  const std::string& reached, const std::string& here)
{
  const PathStep& s = a.steps[k];
  if (!node.IsSequence())
    throw InputError(a.origin + ": '" + reached + "' is not a list in the scene");
  if (s.index >= static_cast<long>(node.size()))
    throw InputError(a.origin + ": '" + reached + "' has " + std::to_string(node.size())
                     + " items, so " + here + " does not exist (indices start at 0)");
  if (k + 1 == a.steps.size())
    node[s.index] = a.value;
  else
  {
    YAML::Node child = node[s.index];
    node.reset(child);
  }
}

/// Step k, a key: into that key of the mapping `node` (made one if it is
/// empty), or set it if last.  A missing key stays for the reader to name the
/// nearest valid one, unless a list index follows it.
void descend_key(YAML::Node& node, const Assignment& a, std::size_t k,
                 const std::string& reached, const std::string& here)
{
  const PathStep& s = a.steps[k];
  if (node.IsNull() or !node.IsDefined())
    node = YAML::Node(YAML::NodeType::Map);
  if (node.IsSequence())
    throw InputError(a.origin + ": '" + reached + "' is a list: name an item, " + reached
                     + "[N]." + s.key);
  if (!node.IsMap())
    throw InputError(a.origin + ": '" + reached + "' is a value, not a mapping with keys");
  if (k + 1 == a.steps.size())
    node[s.key] = a.value;
  else
  {
    if (!node[s.key] and a.steps[k + 1].index >= 0)
    {
      std::vector<std::string> keys;
      for (auto it = node.begin(); it != node.end(); ++it)
        keys.push_back(it->first.Scalar());
      throw InputError(a.origin + ": the scene has no list '" + here + "'"
                       + did_you_mean(s.key, keys));
    }
    YAML::Node child = node[s.key];
    node.reset(child);
  }
}
} // namespace

/// A key that the scene may not have is left to the reader, which names the
/// nearest valid one; a path through a missing list or a scalar stops here.
void apply_override(YAML::Node& root, const std::string& assignment, Source& source)
{
  const Assignment a = parse_assignment(assignment);
  YAML::Node node;
  node.reset(root);
  std::string reached; // the dotted path walked so far, for messages
  for (std::size_t k = 0; k < a.steps.size(); ++k)
  {
    const PathStep& s = a.steps[k];
    const std::string here = s.index >= 0 ? reached + "[" + std::to_string(s.index) + "]"
                                          : (reached.empty() ? s.key : reached + "." + s.key);
    if (s.index >= 0)
      descend_item(node, a, k, reached, here);
    else
      descend_key(node, a, k, reached, here);
    reached = here;
  }
  source.overrides[a.path] = a.origin;
}

} // namespace muscle::scene_input
