// The bench's LAMMPS scripts: the bare kernel keeps the set-up, the pair style and nve/sphere, and nothing that
// loads, damps or measures the scene.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "run/bench_lammps.hpp"

namespace celldem {
namespace {

const std::string kScript =
    "units           si\n"
    "newton          on\n"
    "variable        steps index 500000\n"
    "read_data       ${data}\n"
    "pair_style      gran/hooke/history 1e+06 1e+06 0.0 0.0 0.5 0\n"
    "pair_coeff      * *\n"
    "timestep        1e-06\n"
    "fix             int all nve/sphere\n"
    "fix             bdr all langevin 0.0 0.0 1.0 4928459 omega yes\n"
    "fix             bdt all viscous 1.0\n"
    "compute         P all pressure NULL virial\n"
    "variable        s11 equal c_P[1]\n"
    "fix             dfm all deform 1 x erate -0.2 remap x\n"
    "fix             srv all press/berendsen y 1e+05 1e+05 6.7e-06\n"
    "thermo          1000\n"
    "# one run per test\n"
    "run             ${steps}\n";

TEST(BareLammpsScript, KeepsThePairStyleAndTheIntegratorOnly) {
  const std::string bare = bare_lammps_script(kScript);
  for (const char* kept : {"newton          on", "read_data", "pair_style      gran/hooke/history", "timestep",
                           "fix             int all nve/sphere", "run             ${steps}"})
    EXPECT_NE(bare.find(kept), std::string::npos) << kept << " is missing from\n" << bare;
  for (const char* dropped : {"langevin", "viscous", "compute", "deform", "berendsen", "s11", "thermo          1000"})
    EXPECT_EQ(bare.find(dropped), std::string::npos) << dropped << " is still in\n" << bare;
  EXPECT_LT(bare.find("nve/sphere"), bare.find("run "));
}

TEST(BareLammpsScript, AScriptWithoutItsIntegratorIsRefused) {
  std::string script = kScript;
  script.erase(script.find("fix             int"), std::string("fix             int all nve/sphere\n").size());
  EXPECT_THROW(bare_lammps_script(script), std::runtime_error);
}

}  // namespace
}  // namespace celldem
