#include <loadcases/cube_fe.h>
#include <dolfinx/common/log.h>
#include <petscsys.h>
#include <cstdio>
using namespace muscle;
int main(int argc, char** argv){
  PetscInitialize(&argc,&argv,nullptr,nullptr);
  loguru::g_stderr_verbosity = loguru::Verbosity_WARNING;
  {
    ParameterSet p(Model::giant);
    MaterialPointModel mp(p);
    CubeLoadCase cube(p, MuscleState::active, LoadCase::PSTF);
    for (double s = 1.0; s <= 1.61; s += 0.05) {
      auto r = cube.advance_to(s);
      auto ps = cube.problem().post_fields();
      printf("s=%.2f fe=%.4f exact=%.4f V=%.5f lam=%.4f it=%d\n", s, r.stress, exact_response(mp, LoadCase::PSTF, s).stress, r.volume_ratio, ps.fibre_stretch->x()->array()[0], r.newton_iterations);
    }
  }
  PetscFinalize();
}
