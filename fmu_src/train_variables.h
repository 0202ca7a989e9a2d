/* The variables of the gear-train FMU (GearTrain.so, model_train.c): one source for the binary
 * and for the scene tooling that writes a train FMU's modelDescription.xml
 * (python/gearmesh/train_fmu.py reads this file). A value reference is a block base plus the
 * member's index times the block's stride plus the field; a train FMU lists the members its
 * scene has, under the scene's names (the binary's own names, used in its messages, are the
 * generic ones: body3.speed, shaft1.torque, mesh2.te).
 *
 * Fields: X(field, name, type, causality, variability, unit, description). */
#ifndef GEARMESH_TRAIN_VARIABLES_H
#define GEARMESH_TRAIN_VARIABLES_H

#define TRAIN_GUID "{8c4e8f0a-7d1b-4c5e-9a6f-2b3d4e5f6a71}"
#define TRAIN_MAX_BODIES 32
#define TRAIN_MAX_SHAFTS 32
#define TRAIN_MAX_MESHES 32
#define TRAIN_STRIDE 16
#define TRAIN_BODY_BASE 1000
#define TRAIN_SHAFT_BASE 2000
#define TRAIN_MESH_BASE 3000
/* FMI 3.0's independent variable `time`: the value reference after the table (model_train.c) */
#define TRAIN_TIME_VR 3512

#define TRAIN_SCALAR_FIELDS(X)                                                                                   \
  X(1, "dynamics.tolerance", Real, parameter, fixed, "m", "local error of the rim motion per internal step")    \
  X(2, "dynamics.max_step", Real, parameter, fixed, "s", "largest internal step")                              \
  X(3, "dynamics.min_step", Real, parameter, fixed, "s", "smallest internal step before a step is discarded")   \
  X(4, "energy.kinetic", Real, output, continuous, "J", "kinetic energy of the bodies")                         \
  X(5, "energy.elastic", Real, output, continuous, "J", "elastic energy of the meshes and shafts")              \
  X(6, "energy.initial", Real, output, continuous, "J", "kinetic + elastic energy at the start")                \
  X(7, "energy.work_in", Real, output, continuous, "J", "work put in at the torques and far ends")              \
  X(8, "energy.work_out", Real, output, continuous, "J", "work taken out at the torques and far ends")          \
  X(9, "energy.friction", Real, output, continuous, "J", "friction loss of the meshes")                         \
  X(10, "energy.damping", Real, output, continuous, "J", "loss in contact and shaft dampers")                   \
  X(11, "energy.parametric", Real, output, continuous, "J", "the meshes' non-conservative work")                \
  X(12, "energy.residual", Real, output, continuous, "J", "integration error: + lost, - made")                  \
  X(13, "dynamics.steps", Integer, output, discrete, "", "internal steps of the last step")                     \
  X(14, "dynamics.rejected", Integer, output, discrete, "", "internal steps rejected in the last step")     \
  X(15, "model.quasi_static", Integer, parameter, fixed, "", "1: each step is the static equilibrium (speeds 0) with static.held_body at static.held_angle; 0: the dynamics") \
  X(16, "static.held_body", Integer, parameter, fixed, "", "quasi-static: the body held at static.held_angle (1 = the first body)") \
  X(17, "static.held_angle", Real, input, continuous, "rad", "quasi-static: the held body's angle")

#define TRAIN_BODY_FIELDS(X)                                                                                     \
  X(0, "inertia", Real, parameter, fixed, "kg.m2", "inertia about the spin axis (0 for a fixed body)")          \
  X(1, "phi", Real, input, continuous, "rad", "initial spin angle (read at initialization)")                  \
  X(2, "omega", Real, input, continuous, "rad/s", "initial spin speed (read at initialization)")               \
  X(3, "torque", Real, input, continuous, "N.m", "external torque about +z, held over a step")                \
  X(4, "angle", Real, output, continuous, "rad", "spin angle")                                                 \
  X(5, "speed", Real, output, continuous, "rad/s", "spin speed")                                               \
  X(6, "holding_torque", Real, output, continuous, "N.m", "torque that holds a fixed body (or the held body of the quasi-static mode; 0 if free)") \
  X(7, "mass", Real, parameter, fixed, "kg", "mass of a body whose centre translates on its bearing (0: it does not)") \
  X(8, "bearing_stiffness", Real, parameter, fixed, "N/m", "bearing stiffness per axis (with a mass; 0: floating)") \
  X(9, "bearing_damping", Real, parameter, fixed, "N.s/m", "bearing damping per axis (with a mass)")        \
  X(10, "pin_error_tangential", Real, parameter, fixed, "m", "a planet's centre off its place along the carrier's turning") \
  X(11, "pin_error_radial", Real, parameter, fixed, "m", "a planet's centre off its place, outwards")       \
  X(12, "x", Real, output, continuous, "m", "centre's displacement along the housing's x (translating bodies)") \
  X(13, "y", Real, output, continuous, "m", "centre's displacement along the housing's y (translating bodies)") \
  X(14, "load_torque", Real, input, continuous, "N.m", "external torque in the body's own sense of rotation (the sense it turns in when the train runs forwards: a drive +, a brake -), held over a step; adds to torque") \
  X(15, "forward_speed", Real, output, continuous, "rad/s", "spin speed in the body's own sense of rotation (> 0 when the train runs forwards)")

#define TRAIN_SHAFT_FIELDS(X)                                                                                    \
  X(0, "stiffness", Real, parameter, fixed, "N.m/rad", "torsional stiffness")                                  \
  X(1, "damping", Real, parameter, fixed, "N.m.s/rad", "torsional damping")                                    \
  X(2, "far_phi", Real, input, continuous, "rad", "far end's angle at the step start (port shafts)")          \
  X(3, "far_omega", Real, input, continuous, "rad/s", "far end's speed, held over the step (port shafts)")    \
  X(4, "torque", Real, output, continuous, "N.m", "the shaft's torque on its body (the far end feels minus it)") \
  X(5, "forward_phi", Real, input, continuous, "rad", "far end's angle at the step start in its body's own sense (port shafts; adds to far_phi)") \
  X(6, "forward_omega", Real, input, continuous, "rad/s", "far end's speed in its body's own sense, held over the step (port shafts; adds to far_omega)") \
  X(7, "forward_torque", Real, output, continuous, "N.m", "the shaft's torque on its body in the body's own sense")

#define TRAIN_MESH_FIELDS(X)                                                                                     \
  X(0, "te", Real, output, continuous, "m", "transmission error of the mesh's element, whole base pitches taken off")                       \
  X(1, "normal_force", Real, output, continuous, "N", "normal force")                                          \
  X(2, "max_load_share", Real, output, continuous, "", "share of the force on the most loaded tooth pair")     \
  X(3, "friction_power", Real, output, continuous, "W", "friction loss")                                       \
  X(4, "stiffness", Real, output, continuous, "N/m", "tangent mesh stiffness")                                 \
  X(5, "elastic_energy", Real, output, continuous, "J", "elastic energy")                                      \
  X(6, "flank", Integer, output, discrete, "", "0 none, 1 flank A, 2 flank B, 3 both")                         \
  X(7, "pairs_in_contact", Integer, output, discrete, "", "loaded tooth pairs")                                 \
  X(8, "planet_share", Real, output, continuous, "", "share of its planet group's normal force (the meshes of one pair scene on one carrier; 1 outside a group)")

/* Resources of a train FMU (written by python/gearmesh/train_fmu.py):
 *   resources/train.txt: "gearmesh-train 1", then one line per member, in index order:
 *     body <name> <inertia kg m^2> <fixed 0|1> <initial angle rad, the start of <body>.phi>
 *          [<mass kg> <bearing stiffness N/m> <bearing damping N s/m> <pin error tangential m> <radial m>
 *           [<own sense of rotation: +1 or -1, the sign of its speed when the train runs forwards>]]
 *     shaft <name> <body> <other body or -1: far end> <stiffness> <damping>
 *     mesh <name> <gear1 body> <gear2 body> <carrier body or -1> <orientation rad> [<planet group, 0: none>]
 *   resources/mesh<k>/gearmesh-start-values.txt: the k-th mesh's element parameters (k from 1),
 *     in the format of the pair FMU's start values (fmu_src/values.h). */
#define TRAIN_FILE "train.txt"

#endif /* GEARMESH_TRAIN_VARIABLES_H */
