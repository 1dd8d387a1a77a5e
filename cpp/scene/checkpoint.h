#pragma once

#include <dolfinx/fem/Function.h>
#include <nlohmann/json.hpp>
#include <memory>
#include <string>
#include <vector>

namespace muscle
{

/// The last converged state of a run: the displacement and, in dynamics, the
/// velocity, acceleration and forces (`fields`, one space) at every node,
/// keyed by its coordinates so a run can resume on any number of ranks, and
/// the run's counters in `state` (time, step, sub-step, ...).
///
/// Files: DIR/checkpoint_STEP.bin, then DIR/checkpoint.json naming it, each
/// written to a temporary name and renamed; the previous binary is removed
/// last -- a run killed at any moment leaves a consistent pair.
void write_checkpoint(const std::vector<std::shared_ptr<dolfinx::fem::Function<double>>>& fields,
                      const std::string& directory, const nlohmann::json& state);

/// Read DIR/checkpoint.json and set the fields from DIR/checkpoint.bin
/// (collective).  InputError if there is no usable checkpoint, it holds other
/// fields, or a node is not in it.
nlohmann::json
read_checkpoint(const std::vector<std::shared_ptr<dolfinx::fem::Function<double>>>& fields,
                const std::string& directory);

} // namespace muscle
