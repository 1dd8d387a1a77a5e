#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace muscle
{

/// A mistake in what the user asked for (bad option, parameter, scene entry).
/// Programs print the message and exit with status 2, never a stack trace.
class InputError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// A computation that could not be completed (for example a Newton failure
/// after all cutbacks).  Programs print the message and exit with status 3.
class SolveError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Exit statuses shared by all binaries.
enum ExitStatus : int
{
  exit_ok = 0,
  exit_input_error = 2,
  exit_solve_error = 3,
  exit_internal_error = 4,
};

/// The whole of `text` read as a number (strtod syntax, nothing left over);
/// nothing if it is not one, or if it is NaN or infinite and `finite` is asked.
std::optional<double> parse_real(const std::string& text, bool finite = true);

/// Levenshtein distance, for "did you mean" suggestions.
std::size_t edit_distance(const std::string& a, const std::string& b);

/// The candidate closest to `word`, or "" when none is reasonably close.
std::string nearest(const std::string& word,
                    const std::vector<std::string>& candidates);

/// "a, b, c" for error messages.
std::string join(const std::vector<std::string>& items,
                 const std::string& separator = ", ");

/// ` (did you mean 'x'?)` or "".
std::string did_you_mean(const std::string& word,
                         const std::vector<std::string>& candidates);

} // namespace muscle
