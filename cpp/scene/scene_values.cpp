// Values that several sections of a scene take alike (a component, a file,
// a formula, a vector, an optional list, a pair of surfaces), so that they
// are checked and reported alike.
#include "scene/scene_sections.h"

#include "common/errors.h"

#include <filesystem>

namespace muscle::scene_input
{
namespace
{
std::string resolve(const std::string& directory, const std::string& path)
{
  std::filesystem::path p(path);
  return p.is_absolute() ? path : (std::filesystem::path(directory) / p).lexically_normal().string();
}
} // namespace

int parse_component(const Entry& e)
{
  const std::string c = e.choice({"x", "y", "z", "0", "1", "2"});
  return c == "x" or c == "0" ? 0 : c == "y" or c == "1" ? 1 : 2;
}

std::string existing_file(const Entry& e, const std::string& directory)
{
  const std::string path = resolve(directory, e.text());
  std::error_code error; // a name the system refuses (too long, ...) is not found either
  if (!std::filesystem::is_regular_file(path, error))
    e.fail("file '" + e.text() + "' not found (looked for " + path + ")");
  return path;
}

Expression expression(const Entry& e, const std::vector<std::string>& variables)
{
  try
  {
    return Expression(e.text(), variables);
  }
  catch (const InputError& error)
  {
    e.fail(error.what());
  }
}

std::array<double, 3> vector3(const Entry& e, const std::string& what)
{
  if (!e.is_sequence() or e.size() != 3)
    e.fail("expected " + what + " [x, y, z], found " + e.shown());
  std::array<double, 3> v;
  for (std::size_t d = 0; d < 3; ++d)
    v[d] = e.at(d).number();
  return v;
}

bool list_given(const Entry& e, const std::string& items)
{
  if (!e.defined())
    return false;
  if (!e.is_sequence())
    e.fail("expected a list of " + items + ", found " + e.shown());
  return true;
}

std::array<std::string, 2> surface_pair(const Entry& e, const std::string& role,
                                        const std::string& same)
{
  if (!e.is_sequence() or e.size() != 2)
    e.fail("expected [SLAVE, MASTER]: " + role + "; found " + e.shown());
  std::array<std::string, 2> surfaces;
  surfaces[0] = e.at(0).text();
  surfaces[1] = e.at(1).text();
  if (surfaces[0] == surfaces[1])
    e.fail(same);
  return surfaces;
}

} // namespace muscle::scene_input
