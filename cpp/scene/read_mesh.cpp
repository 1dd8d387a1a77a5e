// The scene's mesh (a Gmsh file, with numbers for a .geo) and its element.
#include "scene/scene_sections.h"

#include "common/errors.h"
#include "fem/elements/element_choice.h"

#include <filesystem>

namespace muscle::scene_input
{
namespace
{
void check_taylor_hood(const Entry& el, const MeshSpec& mesh)
{
  if (mesh.degree != 2)
    el["taylor_hood"].fail("the Taylor-Hood element has a degree-2 displacement (Q2-Q1, "
                           "P2-P1): set element.degree: 2");
  if (mesh.fbar.value_or(false) or mesh.volumetric_quadrature_degree >= 0)
    el["taylor_hood"].fail("Taylor-Hood is an element of its own: not with fbar or "
                           "volumetric_quadrature_degree");
  if (mesh.quadrature_degree >= 0)
    el["taylor_hood"].fail("Taylor-Hood is compiled with the default quadrature degree "
                           "(4); leave quadrature_degree out");
}
} // namespace

void read_mesh(const Entry& top, const std::string& directory, MeshSpec& mesh)
{
  const Entry m = top.required("mesh");
  m.require_map({"file", "set"});
  mesh.where = m.where();
  const Entry mf = m.required("file");
  mesh.path = existing_file(mf, directory);
  const std::string ext = std::filesystem::path(mesh.path).extension().string();
  if (ext != ".geo" and ext != ".msh")
    mf.fail("'" + mf.text() + "' must be a Gmsh .geo or .msh file");
  if (m["set"].defined())
  {
    if (!m["set"].is_map())
      m["set"].fail("expected a mapping NAME: NUMBER (Gmsh -setnumber), found "
                    + m["set"].shown());
    if (ext != ".geo")
      m["set"].fail("numbers can only be set for a .geo file");
    for (const std::string& k : m["set"].keys())
      mesh.numbers[k] = m["set"][k].number();
    mesh.numbers_where = m["set"].where();
  }
}

void read_element(const Entry& top, MeshSpec& mesh)
{
  const Entry el = top["element"];
  if (!el.defined())
    return;
  el.require_map(
      {"degree", "quadrature_degree", "volumetric_quadrature_degree", "fbar", "taylor_hood"});
  mesh.degree = el["degree"].integer(1, 1, 2);
  mesh.quadrature_degree = el["quadrature_degree"].integer(-1, 1, 12);
  mesh.volumetric_quadrature_degree = el["volumetric_quadrature_degree"].integer(-1, 1, 12);
  if (el["fbar"].defined())
  {
    mesh.fbar = el["fbar"].flag(false);
    mesh.fbar_where = el["fbar"].where();
    if (*mesh.fbar)
      try
      {
        check_fbar_request(mesh.degree, mesh.volumetric_quadrature_degree >= 0);
      }
      catch (const InputError& e)
      {
        el["fbar"].fail(e.what());
      }
  }
  mesh.taylor_hood = el["taylor_hood"].flag(false);
  if (mesh.taylor_hood)
    check_taylor_hood(el, mesh);
}

} // namespace muscle::scene_input
