#pragma once

#include <string>
#include <vector>

namespace muscle
{

/// Run one of the project's matplotlib scripts (under the source tree) with
/// Debian's python3.  Plots are a convenience: if python or matplotlib is
/// missing, print a warning naming the data files and return false; the run
/// itself does not fail.
bool run_plot_script(const std::string& script_relative_path,
                     const std::vector<std::string>& arguments);

} // namespace muscle
