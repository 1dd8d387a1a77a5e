#pragma once

#include <petscvec.h>

namespace muscle
{

/// A saddle vector pair [u | q] (read, write) with their u parts placed in
/// `u_in`, `u_out` and, if given, their q parts in `q_in`, `q_out` (vectors
/// without arrays of their own) for the scope: the sub-solvers of a block
/// preconditioner work on the parts without copies.
struct SaddleParts
{
  SaddleParts(Vec in, Vec out, Vec u_in, Vec u_out, Vec q_in = nullptr, Vec q_out = nullptr)
      : _in(in), _out(out), _parts{u_in, u_out, q_in, q_out}
  {
    VecGetArrayRead(in, &x);
    VecGetArray(out, &y);
    VecGetLocalSize(u_in, &nu);
    VecPlaceArray(u_in, x);
    VecPlaceArray(u_out, y);
    if (q_in)
    {
      VecPlaceArray(q_in, x + nu);
      VecPlaceArray(q_out, y + nu);
    }
  }
  ~SaddleParts()
  {
    for (Vec v : _parts)
      if (v)
        VecResetArray(v);
    VecRestoreArray(_out, &y);
    VecRestoreArrayRead(_in, &x);
  }
  SaddleParts(const SaddleParts&) = delete;
  SaddleParts& operator=(const SaddleParts&) = delete;
  const PetscScalar* x; ///< the whole input: u part, then q
  PetscScalar* y;       ///< the whole output
  PetscInt nu;          ///< entries of the u part

private:
  Vec _in, _out;
  Vec _parts[4];
};

} // namespace muscle
