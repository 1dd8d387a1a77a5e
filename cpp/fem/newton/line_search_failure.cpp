#include "fem/newton/line_search_failure.h"

#include <algorithm>
#include <cstdio>

namespace muscle
{

std::string line_search_failure(const NewtonReport& report, const std::string& method)
{
  if (report.reason.find("theta away from J0(u)") != std::string::npos)
    return "the line search (" + method + ") stopped before F-bar's constraint theta = "
           "J0(u) was met";
  if (report.reason.find("LINE SEARCH CREEPING") != std::string::npos)
    return "the line search (" + method + ") crept: it accepted only a small fraction of "
           "each Newton step";
  if (report.reason.find("DIVERGED_LINE_SEARCH") != std::string::npos)
    return "the line search (" + method + ") found no step that lowers the residual";
  std::vector<double> lambda = report.step_lengths;
  // a few steps say nothing about a trend; basic always takes lambda = 1
  if (lambda.size() < 3 or report.non_finite)
    return "";
  std::nth_element(lambda.begin(), lambda.begin() + lambda.size() / 2, lambda.end());
  const double median = lambda[lambda.size() / 2];
  if (!(median < 0.1))
    return "";
  char text[200];
  std::snprintf(text, sizeof text,
                "the line search (%s) cut the Newton steps to a median length of %.1e of the "
                "full step over %zu iterations while the residual stalled",
                method.c_str(), median, lambda.size());
  return text;
}

std::string line_search_advice(const std::string& method)
{
  std::string others;
  for (const std::string& m : NewtonOptions::line_searches())
    if (m != method)
      others += (others.empty() ? "" : ", ") + m;
  const std::string other = method == "basic" ? "cp" : "basic";
  return "another line search (" + others + "; basic takes full Newton steps): scene "
         "solver.line_search, muscle-run --set solver.line_search=" + other
         + ", fusiform --line-search " + other
         + " (BENCHMARKS.md, \"Line searches\"); then a smaller time step";
}

} // namespace muscle
