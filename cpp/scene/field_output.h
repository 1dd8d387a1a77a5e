#pragma once

#include "scene/scene.h"

#include <dolfinx/fem/Function.h>
#include <memory>
#include <string>

namespace dolfinx::io
{
class XDMFFile;
}

namespace muscle
{
struct SceneModel;
class ContactFields;

/// The fields of the whole body: each part's post-processing fields (fibre
/// stretch and stress, von Mises stress and strain, J) on its own cells, the
/// fibre directions, and with contact the pressure and gap.  Written to an
/// XDMF file for ParaView and to surface.json.
class FieldOutput
{
public:
  /// `path`: the XDMF file, written with the mesh and the fibres at `t`; empty:
  /// no XDMF file.
  FieldOutput(const SceneModel& model, const std::string& path, double t);
  ~FieldOutput();

  /// u, the post-processing fields and the contact fields at t into the XDMF
  /// file (nothing without one).  Collective.
  void write(double t);

  /// surface.json: the deformed surface with the fields.  Collective.
  void write_surface(const std::string& path);

private:
  const SceneModel& _model;
  std::unique_ptr<dolfinx::io::XDMFFile> _xdmf;
  std::unique_ptr<ContactFields> _contact; ///< null without contact pairs
};

} // namespace muscle
