// What the data determine: the singular values and directions of the
// Jacobian at the solution, and the parameters' standard errors.
#include "fit/fit_internal.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace muscle::fit
{
namespace
{
using detail::inf;

/// The columns `seen` of `M`.
Eigen::MatrixXd columns(const Eigen::MatrixXd& M, const std::vector<std::size_t>& seen)
{
  Eigen::MatrixXd out(M.rows(), seen.size());
  for (std::size_t k = 0; k < seen.size(); ++k)
    out.col(k) = M.col(seen[k]);
  return out;
}

/// Singular values of N (columns `seen`), and the directions of the small ones.
void find_weak_combinations(const Eigen::MatrixXd& Ns, const std::vector<std::size_t>& seen,
                            Identifiability& id)
{
  const std::size_t ns = std::min<std::size_t>(Ns.rows(), seen.size());
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Ns, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const Eigen::MatrixXd& V = svd.matrixV();
  for (int k = 0; k < sv.size(); ++k)
    id.singular_values.push_back(sv(k));
  for (std::size_t k = 0; k < seen.size(); ++k)
  {
    // m < n leaves directions without a singular value: undetermined too
    const double value = k < ns ? sv(k) : 0.0;
    if (value >= Identifiability::poorly_determined_limit)
      continue;
    Identifiability::Combination c{value, value >= Identifiability::undetermined_limit, {}};
    for (std::size_t q = 0; q < seen.size(); ++q)
      if (std::abs(V(q, k)) >= 0.1)
        c.components.emplace_back(id.names[seen[q]], V(q, k));
    std::sort(c.components.begin(), c.components.end(),
              [](auto& a, auto& b) { return std::abs(a.second) > std::abs(b.second); });
    id.weak.push_back(c);
  }
}

/// Standard errors from the weighted problem, on its determined subspace.
void relative_std_errors(const Eigen::MatrixXd& Js, const std::vector<std::size_t>& seen,
                         const std::vector<double>& residuals, Identifiability& id)
{
  const std::size_t m = Js.rows();
  const std::size_t ns = std::min<std::size_t>(m, seen.size());
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Js, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const Eigen::MatrixXd& V = svd.matrixV();
  std::size_t rank = 0;
  for (std::size_t k = 0; k < ns; ++k)
    if (sv(k) > 1e-9 * sv(0))
      ++rank;
  if (m <= rank)
    return;
  double ss = 0;
  for (double r : residuals)
    ss += r * r;
  const double s2 = ss / static_cast<double>(m - rank);
  for (std::size_t q = 0; q < seen.size(); ++q)
  {
    double var = 0;
    bool in_null = false;
    for (std::size_t k = 0; k < seen.size(); ++k)
    {
      if (k < rank)
        var += V(q, k) * V(q, k) / (sv(k) * sv(k));
      else if (std::abs(V(q, k)) >= 0.1)
        in_null = true;
    }
    id.relative_std_error[seen[q]] = in_null ? inf : std::sqrt(s2 * var);
  }
}

void absolute_std_errors(const std::vector<double>& values,
                         const std::vector<double>& reference, Identifiability& id)
{
  const std::size_t n = id.names.size();
  id.std_error.resize(n);
  for (std::size_t j = 0; j < n; ++j)
  {
    id.std_error[j] = id.relative_std_error[j] * std::abs(reference[j]);
    const bool flagged
        = std::find(id.no_influence.begin(), id.no_influence.end(), id.names[j])
          != id.no_influence.end();
    if (!flagged and std::isfinite(id.relative_std_error[j])
        and id.std_error[j] > std::abs(values[j]))
      id.uncertain.push_back(id.names[j]);
  }
}
} // namespace

std::vector<std::string> Identifiability::flagged() const
{
  std::vector<std::string> out = no_influence;
  for (const std::string& name : uncertain)
    out.push_back(name);
  for (const Combination& c : weak)
    for (const auto& [name, v] : c.components)
      if (std::find(out.begin(), out.end(), name) == out.end())
        out.push_back(name);
  return out;
}

Identifiability analyse_identifiability(const std::vector<double>& jacobian, std::size_t m,
                                        const std::vector<std::string>& names,
                                        const std::vector<double>& values,
                                        const std::vector<double>& reference,
                                        const std::vector<double>& residuals,
                                        const std::vector<double>& row_scale)
{
  const std::size_t n = names.size();
  Identifiability id;
  id.names = names;
  id.relative_std_error.assign(n, inf);
  // J: weighted residuals per relative parameter change; N: the same rows
  // scaled to "relative change of the curve"
  Eigen::MatrixXd J(m, n), N(m, n);
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < n; ++j)
    {
      J(i, j) = jacobian[i * n + j] * std::abs(reference[j]);
      N(i, j) = J(i, j) * row_scale[i];
    }
  std::vector<std::size_t> seen; // columns with influence
  for (std::size_t j = 0; j < n; ++j)
  {
    if (!(N.col(j).norm() > Identifiability::no_influence_limit))
      id.no_influence.push_back(names[j]);
    else
      seen.push_back(j);
  }
  if (seen.empty())
    return id;
  find_weak_combinations(columns(N, seen), seen, id);
  relative_std_errors(columns(J, seen), seen, residuals, id);
  absolute_std_errors(values, reference, id);
  return id;
}

namespace detail
{

std::vector<double> row_scales(const std::vector<DataPoint>& data,
                               const std::vector<double>& sqrt_weights)
{
  // a curve's block then measures the RMS change of that curve relative to
  // its own RMS magnitude
  std::map<CurveKey, std::pair<double, std::size_t>> magnitude; // sum stress^2, count
  for (const DataPoint& d : data)
  {
    auto& [ss, count] = magnitude[{d.load_case, d.state}];
    ss += d.stress * d.stress;
    ++count;
  }
  double largest_rms = 0;
  for (const auto& [k, v] : magnitude)
    largest_rms = std::max(largest_rms, std::sqrt(v.first / v.second));
  std::vector<double> row_scale(data.size(), 0.0);
  for (std::size_t i = 0; i < data.size(); ++i)
  {
    const auto& [ss, count] = magnitude[{data[i].load_case, data[i].state}];
    const double rms = std::max(std::sqrt(ss / count), 1e-3 * largest_rms);
    if (sqrt_weights[i] > 0)
      row_scale[i] = 1 / (sqrt_weights[i] * rms * std::sqrt(double(count)));
  }
  return row_scale;
}

} // namespace detail
} // namespace muscle::fit
