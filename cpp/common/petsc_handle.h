#pragma once

#include <petscksp.h>
#include <petscsnes.h>
#include <utility>

namespace muscle
{

/// Owns one PETSc object (Vec, Mat, KSP, ...): destroyed with the handle, also
/// when a constructor throws half-way.  `out()` hands PETSc's create functions
/// the address to fill (the old object destroyed first); `address()` the
/// address of the object kept, for the calls that reuse it (MatPtAP with
/// MAT_REUSE_MATRIX).
template <typename T, PetscErrorCode (*Destroy)(T*)>
class PetscHandle
{
public:
  PetscHandle() = default;
  /// Takes ownership of `object`.
  explicit PetscHandle(T object) : _object(object) {}
  ~PetscHandle() { reset(); }
  PetscHandle(PetscHandle&& other) noexcept : _object(std::exchange(other._object, nullptr)) {}
  PetscHandle& operator=(PetscHandle&& other) noexcept
  {
    if (this != &other)
    {
      reset();
      _object = std::exchange(other._object, nullptr);
    }
    return *this;
  }
  PetscHandle(const PetscHandle&) = delete;
  PetscHandle& operator=(const PetscHandle&) = delete;

  T get() const { return _object; }
  operator T() const { return _object; }
  explicit operator bool() const { return _object != nullptr; }
  T* out()
  {
    reset();
    return &_object;
  }
  T* address() { return &_object; }
  void reset()
  {
    if (_object)
      Destroy(&_object);
    _object = nullptr;
  }

private:
  T _object = nullptr;
};

using VecHandle = PetscHandle<Vec, VecDestroy>;
using MatHandle = PetscHandle<Mat, MatDestroy>;
using KSPHandle = PetscHandle<KSP, KSPDestroy>;
using SNESHandle = PetscHandle<SNES, SNESDestroy>;
using ISHandle = PetscHandle<IS, ISDestroy>;
using NullSpaceHandle = PetscHandle<MatNullSpace, MatNullSpaceDestroy>;

} // namespace muscle
