#pragma once

// The readers of a scene's sections, called by parse_scene in the order of
// their checks, and the value readers that several sections share.  Each
// reader takes the top-level mapping and fills its part of the scene; a reader
// may check against sections read before it (the parts' densities, say).
#include "scene/scene.h"
#include "scene/scene_yaml.h"

#include <array>
#include <string>
#include <vector>

namespace muscle::scene_input
{

// values (scene_values.cpp, time_function.cpp)
int parse_component(const Entry& e);
std::string existing_file(const Entry& e, const std::string& directory);
Expression expression(const Entry& e, const std::vector<std::string>& variables);
std::array<double, 3> vector3(const Entry& e, const std::string& what);
/// False if the optional list `e` is not given; `items` names what it lists.
bool list_given(const Entry& e, const std::string& items);
/// [SLAVE, MASTER], two different surfaces; `role` says what the slave's
/// points do, `same` why a surface cannot be both.
std::array<std::string, 2> surface_pair(const Entry& e, const std::string& role,
                                        const std::string& same);
/// `allow_model`: 'model', the material's own activation, may be given.
TimeFunction time_function(const Entry& e, bool allow_model);

// mesh and element (read_mesh.cpp)
void read_mesh(const Entry& top, const std::string& directory, MeshSpec& mesh);
void read_element(const Entry& top, MeshSpec& mesh);

// parts: material, fibres, activation (read_parts.cpp)
void read_parts(const Entry& top, const std::string& directory, Scene& scene);

// boundary conditions and ties (read_constraints.cpp)
void read_boundary(const Entry& top, Scene& scene);
void read_ties(const Entry& top, Scene& scene);
void check_uniform_axial(const Scene& scene);

// loads (read_loads.cpp)
void read_loads(const Entry& top, Scene& scene);

// contact (read_contact.cpp)
void read_contacts(const Entry& top, Scene& scene);

// time and dynamics (read_time.cpp)
void read_time(const Entry& top, TimeSteppingOptions& time);
void read_dynamics(const Entry& top, Scene& scene);

// solver (read_solver.cpp)
void read_solver(const Entry& top, Scene& scene);

// output (read_output.cpp)
void read_output(const Entry& top, OutputSpec& output);

} // namespace muscle::scene_input
