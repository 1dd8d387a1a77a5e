#include "io/plotting.h"

#include "common/application.h"

#include <cstdlib>
#include <iostream>

namespace muscle
{
namespace
{
std::string quote(const std::string& s)
{
  std::string out = "'";
  for (char c : s)
    out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}
} // namespace

bool run_plot_script(const std::string& script, const std::vector<std::string>& args)
{
  if (!is_root())
    return true;
  std::string command = std::string(MUSCLE_PYTHON) + " "
                        + quote(std::string(MUSCLE_SOURCE_DIR) + "/" + script);
  for (const std::string& a : args)
    command += " " + quote(a);
  const int status = std::system(command.c_str());
  if (status != 0)
  {
    std::cerr << "warning: plotting with " << script
              << " failed (its error is above; is python3-matplotlib installed?); the data "
                 "files are written"
              << std::endl;
    return false;
  }
  return true;
}

} // namespace muscle
