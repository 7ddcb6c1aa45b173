// The model's named choices, with their deck names in enum order (names[int(value)]).
#pragma once
#include <array>
#include <cstddef>
#include <string>
#include <string_view>

namespace celldem {

enum class TangentialRotation { Rotate, Project };  // keep |xi| when the tangent plane turns, or not (LAMMPS)
enum class MomentArm { ContactPoint, Radius };      // lever arm of the tangential force
enum class Kinematics { Affine, Lammps };           // contacts see the affine velocity difference, or not
// The contact law's sub-models (contact/contact_law.hpp has the equations).
enum class NormalModel { Linear, Hertz };              // kn overlap, or 4/3 E* sqrt(R*) overlap^3/2
// kt, or the no-slip Mindlin 8 G* a (its displacement kept as the contact radius changes, or rescaled by
// a_new / a_old when it shrinks: LAMMPS's `mindlin` and `mindlin_rescale`)
enum class TangentialModel { LinearHistory, Mindlin, MindlinRescale };
enum class RollingModel { None, Sds };                 // no rolling resistance, or spring-dashpot-slider
enum class TwistingModel { None, Marshall };           // no twisting resistance, or Marshall's (from the tangential law)
// How a component of the cell is driven during a leg (cell/control.hpp has the laws). Held: a shear component
// the leg does not name keeps its cell entry as it stands (normal components are always named).
enum class AxisMode { StrainIncrement, StrainRate, Stress, B, MeanStress, ConstantVolume, StressRamp, Held };
// What ends a leg. Strain: the engineering strain of any of the six components (kComponentNames).
enum class LegEndKind { Strain, Ratio, Stress, Steps, SolidFraction, Equilibrium };
// What a control that stays outside its tolerance does: stop the stage (exit 1), or warn and mark the test.
enum class ControlFailure { Stop, Warn };
// How a snapshot's VTK arrays are stored: raw bytes appended after the XML, those bytes zlib-compressed, or text.
enum class SnapshotFormat { Binary, Zlib, Ascii };
// What a grading curve's percentages count: the mass (a sieve curve) or the number of spheres passing.
enum class GradingBasis { Mass, Number };

inline constexpr std::array<std::string_view, 2> kTangentialRotationNames = {"rotate", "project"};
inline constexpr std::array<std::string_view, 2> kMomentArmNames = {"contact_point", "radius"};
inline constexpr std::array<std::string_view, 2> kKinematicsNames = {"affine", "lammps"};
inline constexpr std::array<std::string_view, 2> kNormalModelNames = {"linear", "hertz"};
inline constexpr std::array<std::string_view, 3> kTangentialModelNames = {"linear_history", "mindlin",
                                                                          "mindlin_rescale"};
inline constexpr std::array<std::string_view, 2> kRollingModelNames = {"none", "sds"};
inline constexpr std::array<std::string_view, 2> kTwistingModelNames = {"none", "marshall"};
inline constexpr std::array<std::string_view, 2> kControlFailureNames = {"stop", "warn"};
inline constexpr std::array<std::string_view, 3> kSnapshotFormatNames = {"binary", "zlib", "ascii"};
inline constexpr std::array<std::string_view, 2> kGradingBasisNames = {"mass", "number"};
inline constexpr std::array<std::string_view, 3> kAxisNames = {"x1", "x2", "x3"};
// Probes (tests[].probes, run/probes.hpp): what a probe controls, the plane of stress probes' directions, and
// the named points a probe set starts from (beside strains of axis 1).
enum class ProbeKind { Stress, Strain };
inline constexpr std::array<std::string_view, 2> kProbeKindNames = {"stress", "strain"};
enum class ProbePlane { Rendulic, Deviatoric, List };
inline constexpr std::array<std::string_view, 3> kProbePlaneNames = {"rendulic", "pi", "list"};
inline constexpr std::array<std::string_view, 2> kProbePointNames = {"peak", "end"};
// The shear axes: the tilts h(0,1), h(0,2), h(1,2) of the cell (LAMMPS's xy, xz, yz), each strained
// against the reference length of its column's axis (cell/control.hpp has the convention).
inline constexpr std::array<std::string_view, 3> kShearAxisNames = {"x12", "x13", "x23"};
inline constexpr std::array<std::array<int, 2>, 3> kShearAxisEntries = {{{0, 1}, {0, 2}, {1, 2}}};
// The six controlled components of the cell in Voigt order: the normal axes (kAxisNames), then the shear axes
// (kShearAxisNames); component k is the cell entry h(i, j) of kComponentEntries[k]. Every per-component record
// of the control (targets, stresses, stiffnesses, servo memory, saturation, strains, errors) is in this order.
inline constexpr int kComponents = 6;
inline constexpr std::array<std::string_view, 6> kComponentNames = {"x1", "x2", "x3", "x12", "x13", "x23"};
inline constexpr std::array<std::array<int, 2>, 6> kComponentEntries = {{{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}}};
constexpr bool is_shear_component(int k) { return k >= 3; }
inline std::string component_name(int k) { return std::string(kComponentNames[static_cast<std::size_t>(k)]); }
// The axes a leg's end may name: every component.
inline constexpr const std::array<std::string_view, 6>& kEndAxisNames = kComponentNames;
// The planes of a principal-axis rotation, in the order of the shear axes (x1x2 is x12's plane).
inline constexpr std::array<std::string_view, 3> kPlaneNames = {"x1x2", "x1x3", "x2x3"};

// Mindlin's stiffness 8 G* a, with or without the rescaling.
constexpr bool is_mindlin(TangentialModel t) {
  return t == TangentialModel::Mindlin || t == TangentialModel::MindlinRescale;
}

template <class Enum, std::size_t N>
constexpr std::string_view name_of(Enum value, const std::array<std::string_view, N>& names) {
  return names[static_cast<std::size_t>(value)];
}

}  // namespace celldem
