// The output stage of the evaluation (resultants.cpp), over double and over dual numbers.
#pragma once

#include "model.hpp"

namespace gm {

// The Real outputs of gm_result over a scalar type, and the integer ones.
template <class T>
struct ResultT {
  T force[2][3] = {};
  T moment[2][3] = {};
  T normal_force = 0, stiffness = 0, friction_power = 0, max_line_load = 0;
  T elastic_energy = 0, damping_power = 0;
  int pairs_in_contact = 0, flank = 0;
};


// Elastic potential of the loaded slices at solved forces (before damping), J.
template <class T>
T elastic_energy(const ContactSliceT<T>* slices, const SliceLawT<T>* laws, const T* forces, int n);

// Forces, moments and the other outputs from solved slice forces; forces become the damped
// ones (docs/physics.md §7).
template <class T, class K>
void resultants(const gm_model& m, const ContactSliceT<T>* slices, T* forces,
                const T* slice_stiffness, const K& kin, int n, ResultT<T>& r);

// Load-balance weights of the quasi-static solve (docs/physics.md §6).
template <class T, class K>
void balance_weights(const gm_model& m, const ContactSliceT<T>* slices, const K& kin, int n,
                     T* balance);

}  // namespace gm
