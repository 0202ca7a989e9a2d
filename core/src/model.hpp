// The immutable model and the mutable per-instance data behind the C API's opaque handles.
#pragma once

#include <string>
#include <vector>

#include "contact_forces.hpp"
#include "detection.hpp"
#include "gearmesh/gearmesh.h"

struct gm_model {
  gm_model_params params;      // as given (validated)
  gm_pair_geometry geometry;   // derived at the nominal centre distance
  gm::MeshLayout layout;       // what detection needs, derived once
  int slice_capacity = 0;      // most candidate slices one evaluation can produce
  std::string warnings;        // design warnings, "; "-separated ("" if none)
};

struct gm_data {
  std::vector<gm::ContactSlice> slices;  // candidate slices, capacity fixed at creation
  std::vector<double> forces;            // normal slice forces, N, same capacity
  std::vector<double> slice_stiffness;   // tangent stiffness of each slice, N/m
  std::string message;                   // last error ("" if none)
};
