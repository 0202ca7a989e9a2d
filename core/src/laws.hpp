// The law stage of the evaluation (laws.cpp): per-slice compliance laws, the TE excitation and
// the capability check of the stiffness levels. Over double and over dual numbers (the
// directional derivative).
#pragma once

#include <string>

#include "model.hpp"

namespace gm {

// Check that m can be evaluated by this build (levels and effects implemented so far);
// returns GM_ERR_PARAMETER with msg naming the parameter otherwise.
gm_status check_capabilities(const gm_model_params& p, std::string& msg);

// The TE excitation of the TE table (user_tables.hpp) on n slices at pose kin: a gap along the
// normal of every slice and its rate. Nothing without a table.
template <class T, class K>
void apply_te_excitation(const gm_model& m, ContactSliceT<T>* slices, const K& kin, int n);

// The compliance law of each of n slices (docs/physics.md §5); `all`: also the open slices
// (the quasi-static setting), else only those with a positive approach.
template <class T>
void build_laws(const gm_model& m, const ContactSliceT<T>* slices, SliceLawT<T>* laws, int n,
                bool all);

}  // namespace gm
