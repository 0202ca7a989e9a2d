// Mesh orders over whole mesh cycles in the large-step mode (gearmesh.h, gm_mesh_orders;
// docs/dynamics.md, "Mesh orders").
#pragma once

#include "gearmesh/gearmesh.h"

namespace gm {

// A point of the integrated trajectory: gear 1's angle and the two signals there.
struct OrderPoint {
  double phi1;   // rad
  double value[2];  // TE (m), normal force (N)
};

// Forget everything (the start of the dynamics).
void orders_reset(gm_mesh_orders& o);
// The trajectory from a to b (linear in the mesh angle between them), z1 gear 1's teeth, for
// orders 1 ... n (n <= GM_MESH_ORDERS_MAX).
void orders_add(gm_mesh_orders& o, int z1, int n, const OrderPoint& a, const OrderPoint& b);
// Amplitudes and phases of orders 1 ... n (o.orders) from the last `window` completed cycles (the
// cycles in o.cycles); those past n are 0.
void orders_publish(gm_mesh_orders& o, int window, int n);

}  // namespace gm
