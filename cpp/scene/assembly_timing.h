#pragma once

#include "scene/scene.h"

#include <nlohmann/json.hpp>

namespace muscle
{
struct SceneModel;

/// --measure-assembly: the median times of `count` residual, Jacobian and
/// activation-kernel evaluations of the scene's forms and of the plain passive
/// forms of the same model, printed and returned for summary.json ("assembly");
/// null for count 0.  InputError for a scene of several parts.
nlohmann::json time_assemblies(const Scene& scene, SceneModel& model, int count);

} // namespace muscle
