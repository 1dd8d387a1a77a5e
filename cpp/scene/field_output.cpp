#include "scene/field_output.h"

#include "fem/contact/contact.h"
#include "io/surface_export.h"
#include "scene/scene_model.h"

#include <dolfinx/io/XDMFFile.h>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// Every part's post-processing fields summed: each part fills its own cells.
MuscleProblem::PostFields body_post(const std::vector<MuscleProblem*>& body)
{
  MuscleProblem::PostFields sum = body[0]->post_fields();
  for (std::size_t p = 1; p < body.size(); ++p)
  {
    const MuscleProblem::PostFields more = body[p]->post_fields();
    auto add = [](auto& to, const auto& from)
    {
      std::span<double> x = to->x()->mutable_array();
      std::span<const double> y = from->x()->array();
      for (std::size_t i = 0; i < x.size(); ++i)
        x[i] += y[i];
    };
    const auto to = sum.all(), from = more.all();
    for (std::size_t k = 0; k < to.size(); ++k)
      add(to[k], from[k]);
  }
  return sum;
}

/// The fibre directions of the whole body: each part's on its own cells.
std::shared_ptr<fem::Function<double>> body_fibre(const std::vector<MuscleProblem*>& body)
{
  auto fibre = body[0]->fibre();
  if (body.size() == 1)
    return fibre;
  fibre = std::make_shared<fem::Function<double>>(body[0]->fibre()->function_space());
  fibre->name = "fibre";
  const auto& dofmap = *fibre->function_space()->dofmap();
  std::span<double> out = fibre->x()->mutable_array();
  for (const MuscleProblem* part : body)
  {
    std::span<const double> in = part->fibre()->x()->array();
    for (std::int32_t c : part->cells())
      for (int k = 0; k < 3; ++k)
        out[3 * dofmap.cell_dofs(c)[0] + k] = in[3 * dofmap.cell_dofs(c)[0] + k];
  }
  return fibre;
}
} // namespace

FieldOutput::FieldOutput(const SceneModel& model, const std::string& path, double t)
    : _model(model)
{
  if (!path.empty())
  {
    const auto& mesh = model.gm.mesh;
    const auto fibre = body_fibre(model.body);
    _xdmf = std::make_unique<io::XDMFFile>(mesh->comm(), path, "w");
    _xdmf->write_mesh(*mesh);
    _xdmf->write_function(*fibre, t);
  }
  if (!model.contacts.empty())
    _contact = std::make_unique<ContactFields>(*model.problem().u()->function_space());
}

FieldOutput::~FieldOutput() = default;

void FieldOutput::write(double t)
{
  if (!_xdmf)
    return;
  _xdmf->write_function(*_model.problem().u(), t);
  const MuscleProblem::PostFields post = body_post(_model.body);
  for (const auto& f : post.all())
    _xdmf->write_function(*f, t);
  if (_contact)
  {
    _contact->update(_model.contacts);
    _xdmf->write_function(*_contact->pressure, t);
    _xdmf->write_function(*_contact->gap, t);
  }
}

void FieldOutput::write_surface(const std::string& path)
{
  const MuscleProblem::PostFields post = body_post(_model.body);
  const auto fields = post.all();
  std::vector<std::shared_ptr<const fem::Function<double>>> more(fields.begin(), fields.end());
  if (_contact)
  {
    _contact->update(_model.contacts);
    more.insert(more.end(), {_contact->pressure, _contact->gap});
  }
  export_deformed_surface(*_model.problem().u(), *post.fibre_stretch, path, more);
}

} // namespace muscle
