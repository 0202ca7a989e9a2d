// The immutable model and the mutable per-instance data behind the C API's opaque handles.
#pragma once

#include <string>
#include <vector>

#include <limits>
#include <memory>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

#include "gearmesh/internal/compliance_db.hpp"
#include "contact_forces.hpp"
#include "nlcp.hpp"
#include "detection.hpp"
#include "face_basis.hpp"
#include "fe_compliance.hpp"
#include "stiffness_iso.hpp"
#include "gearmesh/internal/tooth_compliance.hpp"
#include "tooth_coupling.hpp"
#include "coupled_forces.hpp"
#include "user_tables.hpp"
#include "gearmesh/gearmesh.h"

namespace gm {

// What the stages need to know of the stiffness level (its file core/src/level<k>_<name>.hpp, levels.hpp):
// its traits, copied into the model at creation, so that no stage tests the level's number.
struct LevelTraits {
  int id = 0;                 // gm_stiffness_level
  const char* name = "";      // e.g. "analytical"
  bool merges_slices = true;  // repeated slices merged before the laws (slice_merge.hpp)
  bool tooth_law = false;     // the slice law: both teeth's compliance and the local Hertz law
                              // (laws.hpp); false: the level's pair stiffness
  bool database = false;      // the coupled compliance from the gears' databases (fe_compliance.hpp)
  bool coupled = false;       // the coupled force solve (dense_solve.cpp): set at creation
};

}  // namespace gm

struct gm_model {
  gm_model_params params;      // as given (validated)
  gm::LevelTraits level;       // of params.stiffness_level
  gm_pair_geometry geometry;   // derived at the nominal centre distance
  gm::MeshLayout layout;       // what detection needs, derived once
  int slice_capacity = 0;      // most candidate slices one evaluation can produce
  std::string warnings;        // design warnings, "; "-separated ("" if none)
  double iso_c_prime = 0;      // level 2: ISO 6336-1 single stiffness c' (load-corrected), N/m^2
  double iso_c_gamma = 0;      // levels 2, 3: mesh stiffness c_gamma_alpha, N/m^2
  double iso_shape = 0;        // level 2: parabola depth of the pair stiffness over the path
  gm::ToothSection tooth[2];   // level 4: Weber/Sainsot compliance of each gear's tooth
  gm::ToothCoupling coupling;  // level 4: coupling between the teeth of each gear (offsets 0: none)
  gm::StiffnessTable stiffness_table;  // level 1: pair stiffness over gear 1's roll angle
  gm::TeTable te_table;        // any level: TE excitation over gear 1's angle (empty = none)
  gm::ComplianceDb compliance[2];  // level 5: each gear's compliance database (checked to match)
  std::vector<double> face_shapes;  // level 5, solver.face_shapes > 0: the reduced basis's shapes
                                    // (face_shapes.hpp; empty: not attempted)
  std::vector<double> face_shape_products;  // their products per slice (face_shape_products)
};

struct gm_data {
  std::vector<gm::ContactSlice> slices;  // candidate slices, capacity fixed at creation
  std::vector<gm::SliceLaw> laws;        // their compliance laws, same capacity
  std::vector<double> approach;          // approaches handed to the solve, m
  std::vector<double> balance;           // quasi-static load-balance weights, -
  std::vector<double> forces;            // normal slice forces, N, same capacity
  std::vector<double> slice_stiffness;   // tangent stiffness of each slice, N/m
  double te_estimate = 0;                // quasi-static: last solved TE (warm start), m
  // Level 5 quasi-static: the last three solved (gear 1 angle, TE, load torque), newest first, from
  // which the next call's TE estimate is extrapolated. Derived data: valid only while the
  // coupled solve's warm start is (dense_prev_n >= 0), so a reset or restored state starts from
  // te_estimate alone.
  struct TeHistory {
    double phi[3] = {0, 0, 0}, te[3] = {0, 0, 0}, load[3] = {0, 0, 0};  // rad, m, N m
    int n = 0;                                                // entries held
  } te_history;
  // the dense coupled solve (dense_solve.cpp; levels 5 and 4 with tooth coupling): its workspace,
  // sized to the slice capacity at creation
  std::unique_ptr<gm::NlcpSolver> nlcp;
  Eigen::MatrixXd dense_c;         // C = C1 + C2 between the solved slices, m/N
  Eigen::MatrixXd dense_tangent;            // C_AA + diag f'_A, factorized in place (stiffness)
  Eigen::VectorXd dense_delta, dense_force, dense_weights, dense_work;
  std::vector<gm::LocalLaw> dense_laws;     // local Hertz laws of the solved slices
  std::vector<int> dense_index;             // candidate index of each solved slice
  std::vector<double> dense_height;         // level 4 coupled: heights of the solved slices (gear 1, 2)
  gm::CoupledWorkspace coupled;          // level 4 coupled: the low-rank solve (coupled_forces.hpp)
  std::vector<long long> dense_key, dense_prev_key;  // slice identities (warm start if unchanged)
  int dense_prev_n = -1;                    // solved slices of the previous call (-1: none)
  // elastic energy of the coupled solve's answer from the laws it holds there (dense_solve.cpp),
  // J; NaN: this evaluation has none (resultants.hpp's elastic_energy computes it)
  double dense_energy = std::numeric_limits<double>::quiet_NaN();
  gm::FeAssembly fe_assembly;            // cached face sums of the databases (derived data)
  gm::FaceBasis face;                    // level 5, solver.face_shapes > 0: the reduced solve
  Eigen::MatrixXd dense_dual_c;             // derivative: dC between the loaded slices, m/N
  gm::FeDualAssembly fe_dual_assembly;   // derivative: level 5's C and dC (its scratch)
  Eigen::VectorXd dense_saved_force;        // derivative: the warm start, restored afterwards
  std::vector<long long> dense_saved_key;
  // gm_directional_derivative's scratch: the same per slice, over dual numbers
  std::vector<gm::ContactSliceT<gm::Dual>> dual_slices;
  std::vector<gm::SliceLawT<gm::Dual>> dual_laws;
  std::vector<gm::Dual> dual_forces, dual_stiffness, dual_balance;
  // The loaded slices of the last gm_evaluate (gm_data_load_distribution), recorded as it
  // stores its outputs: the passes that follow (a directional derivative, a quasi-static pass)
  // reuse the candidate arrays.
  struct LoadedSlice {
    int pair, slice, run, flank;
    double force, width, path_position, approach;
  };
  std::vector<LoadedSlice> loaded;       // capacity fixed at creation
  int loaded_count = 0;
  std::string message;                   // last error ("" if none)
};

namespace gm {

// The per-candidate arrays of d that a pass over scalar type T fills and its stages read:
// d.slices, d.laws, d.forces, d.slice_stiffness and d.balance in double, the dual_ ones over dual
// numbers (the directional derivative's passes). candidates<T>(d).
template <class T>
struct Candidates {
  ContactSliceT<T>* slices;
  SliceLawT<T>* laws;
  T* forces;      // normal slice forces, N
  T* stiffness;   // tangent stiffness of each slice, N/m
  T* balance;     // quasi-static load-balance weights, -
};
template <class T>
Candidates<T> candidates(gm_data& d);
// The scalar type of kinematics K: double (gm_kinematics) or Dual (KinematicsT<Dual>).
template <class K>
using ScalarOf = std::decay_t<decltype(std::declval<const K&>().phi[0])>;
template <>
inline Candidates<double> candidates<double>(gm_data& d) {
  return {d.slices.data(), d.laws.data(), d.forces.data(), d.slice_stiffness.data(), d.balance.data()};
}
template <>
inline Candidates<Dual> candidates<Dual>(gm_data& d) {
  return {d.dual_slices.data(), d.dual_laws.data(), d.dual_forces.data(), d.dual_stiffness.data(),
          d.dual_balance.data()};
}

// The FE level's narrow view of the model (fe_compliance.hpp).
inline FeView fe_view(const gm_model& m) {
  return FeView{m.compliance, m.layout, m.params.coupled_teeth,
                m.face_shapes.empty() ? nullptr : m.face_shapes.data(), m.params.solver_face_shapes};
}


}  // namespace gm
