// Rigid-body model, state and contact layouts shared by the engine and shaders/physics.
// Every struct is a whole number of 16-byte vectors so C++ and HLSL (std430) agree.
#ifndef CRESSIM_RIGID_H
#define CRESSIM_RIGID_H
#include "cressim/types.h"

CRESSIM_SHADER_BEGIN

static const uint CRESSIM_NONE = 0xffffffffu;  // "no body": the world

// shape kinds (ShapeKind in C++)
static const uint SHAPE_SPHERE = 1;   // size.x radius
static const uint SHAPE_BOX = 2;      // size.xyz half extents
static const uint SHAPE_CAPSULE = 3;  // size.x radius, size.y half height along local z
static const uint SHAPE_PLANE = 4;    // static only; the shape frame's +z is the normal

// joint kinds (JointKind in C++); the joint frame's x axis is the hinge/slider axis
static const uint JOINT_FIXED = 1;
static const uint JOINT_BALL = 2;
static const uint JOINT_SPHERICAL = 3;  // ball with a drive to a target relative rotation
static const uint JOINT_HINGE = 4;
static const uint JOINT_SLIDER = 5;

static const uint DRIVE_NONE = 0;
static const uint DRIVE_POSITION = 1;  // spring (stiffness) to the target, damped to rest
static const uint DRIVE_VELOCITY = 2;  // damping (damping) toward the target velocity

static const uint BODY_KINEMATIC = 1;
// in a collider's group: particles pass through it (a suture needle's shapes: only its tip acts
// on tissue); bodies meet it by group and mask as ever
static const uint COLLIDER_NO_PARTICLES = 0x80000000u;
static const uint JOINT_LIMITED = 1;

// per-env health flags (env.health), written by the solver; a flagged env is reset next frame
static const uint HEALTH_NAN = 1;
static const uint HEALTH_SPEED = 2;
static const uint HEALTH_PENETRATION = 4;

struct BodyModel {
  float4 inv_inertia;  // xyz: inverse principal inertia in the body frame; w: inverse mass
  float4 damping;      // x linear, y angular (1/s)
  uint4 ids;           // x entity row, y env, z flags (BODY_*), w unused
};

struct ColliderModel {
  float4 position;  // shape frame in the body frame (world frame when static)
  float4 rotation;  // quaternion xyzw
  float4 size;      // see SHAPE_*
  float4 material;  // x static friction, y dynamic friction, z restitution
  uint4 ids;        // x body (or CRESSIM_NONE), y kind, z group, w mask
};

struct JointModel {
  float4 frame_a_position;  // joint frame in body a (world when a is CRESSIM_NONE)
  float4 frame_a_rotation;
  float4 frame_b_position;  // joint frame in body b
  float4 frame_b_rotation;
  float4 limits;  // x lower, y upper
  float4 drive;   // x stiffness, y damping, z max force (or torque), w compliance of the joint
  uint4 ids;      // x body a, y body b, z kind, w flags (JOINT_LIMITED) | drive mode << 8
};

// each env's slice of the flat arrays
struct EnvRigidRange {
  uint4 bodies;     // x first body, y count, z first collider, w count
  uint4 joints;     // x first joint (in parent-before-child order), y count, z first filtered pair, w count
};

// Multipliers are positional impulses (kg m) on a, accumulated over the substep's iterations; a
// patch is a run of contacts between the same two bodies (xpbd_rigid.comp.hlsl).
struct Contact {
  float4 normal;    // xyz world normal from b to a; w twist lambda about it (kg m^2; patch's first)
  float4 anchor_a;  // xyz point on a in a's frame; w normal lambda
  float4 anchor_b;  // xyz point on b in b's frame (world for static); w pre-solve normal speed
  float4 friction;  // xyz tangential lambda (world; patch's first contact); w velocity-level normal impulse (kg m/s)
  float4 material;  // x static, y dynamic friction, z restitution; w the friction coefficient in use
  uint4 bodies;     // x a, y b, w patch length (in its first contact; 0 in the others)
};

struct RigidConstants {
  float4 gravity;  // xyz; w frame time step
  uint env_count;
  uint substeps;
  uint iterations;
  uint max_contacts;  // per env
  float max_speed;    // health bound (m/s)
  float max_penetration;  // health bound (m)
  uint pad0;
  uint pad1;
};

CRESSIM_SHADER_END
#endif
