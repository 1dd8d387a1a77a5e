#pragma once

#include "common/errors.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

namespace muscle
{

/// Parse a program's own arguments (PETSc options already split off) with
/// CLI11.  Returns false after printing the help text (the program then exits
/// with status 0); a mistake becomes an InputError carrying CLI11's message.
inline bool parse_command_line(CLI::App& app, std::vector<std::string> args)
{
  std::reverse(args.begin(), args.end()); // CLI11 consumes from the back
  try
  {
    app.parse(args);
  }
  catch (const CLI::CallForHelp&)
  {
    std::printf("%s", app.help().c_str());
    return false;
  }
  catch (const CLI::ParseError& e)
  {
    throw InputError(e.what());
  }
  return true;
}

} // namespace muscle
