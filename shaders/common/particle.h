// Particle system layouts shared by the engine and shaders/physics/particle_*: one set of flat
// particle buffers for every kind (soft bodies, fluids, strands) and env, constraint records of a
// common shape, and the per-env / per-object ranges. Every struct is whole 16-byte vectors.
#ifndef CRESSIM_PARTICLE_H
#define CRESSIM_PARTICLE_H
#include "cressim/types.h"

CRESSIM_SHADER_BEGIN

// particle kinds (phase.x)
static const uint PARTICLE_SOLID = 1;   // soft bodies (tetrahedral or meshfree)
static const uint PARTICLE_FLUID = 2;   // position-based fluids
static const uint PARTICLE_STRAND = 3;  // threads and cables

// the most particles one env may have for the one-workgroup-per-env constraint solve (group memory):
// the largest of the `.blockN` builds in cmake/shaders.cmake
static const uint PARTICLE_BLOCK_CAPACITY = 1024;
// That solve's copy of a record (particles.<family>_block_records, a uint4 each): x and y the
// record's particles as indices into its env (16 bits each, low half first; PARTICLE_BLOCK_NONE
// where unused), set by the engine; z the rest value and w the compliance (negative while the
// record is cut), copied from the record each frame by particle_block_pack.
static const uint PARTICLE_BLOCK_NONE = 0xFFFF;
// Thread-group width of the per-env reductions (health, contact forces on bodies): one group an
// env, its threads striding over the env's particles. A thread an env looping over them all was
// the slowest pass of small-env tasks (0.22 ms of 0.59 for 32 envs of 343 particles on an H100).
static const uint PARTICLE_ENV_GROUP = 128;

// neighbour list entries per particle (particles.neighbor_lists), taken once per substep; an
// entry is the neighbour's index with PARTICLE_NEIGHBOR_FLUID set for a fluid particle (its kind
// is what most readers branch on first, and one load fewer a neighbour)
static const uint PARTICLE_MAX_NEIGHBORS = 64;
static const uint PARTICLE_NEIGHBOR_FLUID = 0x80000000u;
// threads a particle building its neighbour list (particle_neighbor_list.comp.hlsl); a power of two
static const uint PARTICLE_LIST_LANES = 4;

// phase.w flags
static const uint PARTICLE_ACTIVE = 1;        // inactive slots (fluid budget) neither move nor collide
static const uint PARTICLE_SELF_COLLIDE = 2;  // collides with particles of its own object
static const uint PARTICLE_ELASTIC = 4;       // moved by an elastic energy (particle_tet): integrated without gravity
static const uint PARTICLE_NO_SOFT_CONTACT = 8;  // no contacts with soft-body particles (a suture thread through tissue)

// Every constraint family stores records of this shape: up to 4 particles and family-specific
// parameters. Records are grouped by colour (no two constraints of a colour share a particle),
// and the family's pass projects one colour per dispatch straight onto the positions: Gauss-Seidel
// between colours, parallel within one, the same for every env. A new family is its name in
// kConstraintFamilies, a record builder and a pass; the solver core only walks the table of sets
// (docs/particles.md, "Adding a family"). Any record can be cut at run time (its flag in
// control.particle_<family>_cut).
struct ParticleConstraint {
  uint4 particles;  // global particle indices (CRESSIM_NONE when unused)
  float4 params;    // x rest value, y compliance, zw family-specific
};

struct ParticleObject {
  uint4 range;      // x first particle, y count, z env, w kind
  uint4 ids;        // x entity row, y flags (PARTICLE_SELF_COLLIDE), z budget (fluid), w slots active at start
  float4 material;  // x radius, y friction, z damping (1/s), w rest density (fluid)
  float4 fluid;     // x viscosity (XSPH), y cohesion, z surface tension, w vorticity confinement
  float4 emitter;   // fluid emitter: xyz nozzle centre (world), w particles per frame (0: none)
  float4 emit_velocity;  // xyz velocity of emitted particles, w nozzle width (particles a side)
  float4 heat;      // elastic bodies with heat: x conductivity (W/m/K; 0: no heat), y specific heat (J/kg/K), z initial temperature (K), w density (kg/m^3)
  float4 burn;      // x ln of the Arrhenius frequency factor (ln 1/s), y activation energy / gas constant (K), z damage onset (K)
  float4 coagulation;  // fully coagulated tissue: x stiffness ratio, y linear shrinkage
};

struct ParticleEnvRange {
  uint4 range;  // x first particle, y count, z first object, w count
};

// A rigid-particle attachment slot (control.particle_attachments, max_particle_attachments_per_env
// per env): state 0 free, 1 attached, 2 attach at the next step (local offset taken from the
// poses then). Written by the host (Engine.attach_particle) or by task passes. A slot may also
// hold a strand segment's material frame to the body's rotation (hold.x the segment), so
// turning the body twists the strand.
static const uint ATTACH_FREE = 0;
static const uint ATTACH_ACTIVE = 1;
static const uint ATTACH_PENDING = 2;
static const uint HOLD_FRAME_CAPTURE = 0;  // hold.y: the frame offset is taken when the slot becomes active
static const uint HOLD_FRAME_GIVEN = 1;    // hold.y: frame is the offset to keep
struct ParticleAttachment {
  uint4 ids;     // x particle, y body (rigid body index), z state, w env
  float4 local;  // xyz particle position in the body frame, w compliance (0: rigid; frames too)
  uint4 hold;    // x strand segment whose frame is held (CRESSIM_NONE: none), y HOLD_FRAME_*
  float4 frame;  // the segment's frame in the body frame (xyzw): frame = body rotation * this
};

// Tendon-driven strands (a Tendons component on a Strand; particle_tendon.comp.hlsl). A robot's
// disks sit at some of its particles and turn with the frame of the segment starting there; each
// tendon runs from the first disk's hole through every disk's to the last's and slides freely.
// control.tendon_commands (float32 (tendons, 2)) drives each: x mode, y value.
static const uint TENDON_SLACK = 0;         // no force
static const uint TENDON_DISPLACEMENT = 1;  // pulled in by y metres from its rest length (a taut, unilateral length)
static const uint TENDON_TENSION = 2;       // pulled with y newtons
struct TendonRobot {
  uint4 range;  // x first disk (particles.tendon_disks: particle, frame), y disks, z first tendon, w tendons
};
struct Tendon {
  float4 route;  // xy the hole in each disk's frame (m), z rest length (m), w compliance (m/N; 0: inextensible)
  uint4 ids;     // x robot, y env
};

// Suturing (a Needle on a rigid body; particle_needle_detect / _solve). A needle's path runs from
// its tip along the arc to its tail (s from 0 to radius x angle) and on along its thread from the
// thread's first particle to its last. A puncture record ties a point of a soft body's surface
// (a surface triangle and barycentric weights) to the tip while it is pushed in (indenting), then
// to the path at s (through), sliding along it against friction.
static const uint PUNCTURE_FREE = 0;
static const uint PUNCTURE_INDENTING = 1;
static const uint PUNCTURE_THROUGH = 2;
struct NeedleModel {
  uint4 ids;       // x rigid body, y the thread's first particle (CRESSIM_NONE: none), z its particles, w env
  uint4 records;   // x first puncture record, y records, z first surface triangle of its env, w triangles
  float4 arc;      // x radius (m), y angle (rad), z puncture force (N), w friction coefficient
  float4 puncture; // x puncture depth (m): the tip's way past where it met the surface, y squeeze (N)
  float4 center;   // xyz the arc's centre in the body frame
  float4 rotation; // the arc's frame in the body frame (xyzw)
};
struct Puncture {
  uint4 ids;      // x state (PUNCTURE_*), y surface triangle (row of particles.surface), z the side the tip came from (1 outside, 0 inside), w 1: the knot holds it
  float4 place;   // xy barycentric weights of the triangle's corners 0 and 1, z path parameter s (m), w the push on the surface (N; indenting)
  float4 contact; // xyz where the tip met the surface (world), w the push (N) when it went through
  float4 force;   // punctured on the thread: xyz the force on the thread (N), w its friction part along it (N), the last substep
  float4 impulse; // the same summed over this substep's iterations, times h^2 (scratch)
};

// push constants of every particle pass
struct ParticleConstants {
  float4 gravity;     // xyz; w substep h
  float4 grid;        // x cell size, y fraction of the frame done at the end of this substep, z max speed, w substeps
  uint particle_count;
  uint item_count;    // threads of this pass (constraints of one colour, blocks...)
  uint table_size;    // hash buckets (power of two)
  uint env_count;
  uint has_rigid;     // rigid buffers are real (else one-element stand-ins)
  uint owns_health;   // no rigid system: the particle health pass writes env.health itself
  uint attachment_count;
  uint item_offset;   // first constraint of the colour this dispatch projects
  uint edge_count;    // strand segments (material frames)
  uint has_pins;      // particles.tet_pins is one per particle (suture needles pin tissue there)
  float cell_inverse; // 1 / grid.x: a cell is floor(x * cell_inverse), one rounding whichever kernel takes it
  uint pad2;
};

// Constraint records address a strand segment's frame as particle_count + segment.

CRESSIM_SHADER_END
#endif
