// Domain randomization on the GPU (cressim/randomization): `sample` draws each env's values of
// every term (a thread per env) at its reset or on its interval; the `apply_*` entries write them
// into the engine's model buffers (a thread per target row: a body, collider, joint, particle
// object or particle, a tet or constraint, a renderable, light, camera transform or probe) from
// the authored values kept in target_nominal, so a draw never compounds; `depth_noise` adds
// gaussian noise of each env's drawn standard deviation to its cameras' depth images (a thread
// per pixel).
// Draws hash (seed, env + env_offset, the term's name, component, the term's draw count in that
// env): seeded, and an env's draws depend neither on the envs beside it nor on the other terms.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/render.h"
#include "cressim/rigid.h"
#include "cressim/ultrasound.h"

// distributions, operations, schedules, parameters (config.py)
static const uint DIST_UNIFORM = 0, DIST_LOG_UNIFORM = 1, DIST_GAUSSIAN = 2, DIST_CHOICE = 3;
static const uint OP_SCALE = 0, OP_ADD = 1, OP_ABS = 2;
static const uint WHEN_RESET = 0, WHEN_INTERVAL = 1;
static const uint PARAM_MASS = 1, PARAM_DAMPING = 2, PARAM_FRICTION = 3, PARAM_RESTITUTION = 4,
                  PARAM_JOINT_STIFFNESS = 5, PARAM_JOINT_DAMPING = 6, PARAM_YOUNGS_MODULUS = 7, PARAM_COLOR = 8,
                  PARAM_LIGHT_INTENSITY = 9, PARAM_LIGHT_COLOR = 10, PARAM_CAMERA_POSITION = 11,
                  PARAM_CAMERA_ROTATION = 12, PARAM_ULTRASOUND_GAIN = 14, PARAM_TEXTURE = 15;

struct Params {
  uint envs;
  uint terms;
  uint columns;     // values per env
  uint seed;
  uint env_offset;  // env 0's index in the whole batch (a shard draws that batch's numbers)
  uint reset_all;   // 1: every term is drawn in every env (reset())
  uint items;       // threads of an apply or noise pass
  uint pixels;      // depth_noise: pixels per layer
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

struct Term {
  uint4 layout;  // x first value column, y components, z distribution | when << 8, w every
  uint4 salt;    // x a hash of the term's name: its draws do not depend on the other terms
};
StructuredBuffer<Term> terms;
StructuredBuffer<float4> columns;    // per value column: x, y range (mean, std; choice: first, count), z, w clip
StructuredBuffer<float> choices;     // the values choice terms draw from
StructuredBuffer<uint> reset_mask;   // env.reset_mask
// a task that starts episodes without the engine's reset (TargetCenter) names its own flags:
// nonzero where an episode ended this step (its terminated and truncated; else env.reset_mask)
StructuredBuffer<uint> ended_a;
StructuredBuffer<uint> ended_b;
RWStructuredBuffer<uint> pending;    // envs reset from the host (Randomizer.reset_envs), cleared once drawn
RWStructuredBuffer<float> values;    // (envs, columns): the drawn values
RWStructuredBuffer<uint> fresh;      // (envs, terms): 1 where the term was drawn or its env reset this frame
RWStructuredBuffer<uint> draws;      // (envs, terms): draws so far
RWStructuredBuffer<uint> counters;   // (envs, terms): steps since the last draw (interval terms)
RWStructuredBuffer<uint> frame;      // [0]: frames sampled (the depth noise's per-frame input)

StructuredBuffer<uint4> target_ids;       // x term, y env, z row in the target buffer, w param | op << 8
StructuredBuffer<float4> target_nominal;  // the authored values the draws act on

uint pcg_hash(uint v) {
  const uint state = v * 747796405u + 2891336453u;
  const uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
// in (0, 1]: never 0, so the log of Box-Muller stays finite
float unit_hash(uint a, uint b, uint c) {
  const uint h = pcg_hash(pc.seed ^ pcg_hash(pcg_hash(a) ^ (b * 0x9e3779b9u + 0x632be5abu)) ^ pcg_hash(c * 7919u + 0x85ebca6bu));
  return (float(h >> 8) + 1.0) * (1.0 / 16777216.0);
}
float gaussian(float u1, float u2) { return sqrt(-2.0 * log(u1)) * cos(6.28318530718 * u2); }

float draw(uint dist, float4 col, uint env, uint salt, uint n) {
  const uint e = env + pc.env_offset;
  const float u = unit_hash(e, 2 * salt, n), u2 = unit_hash(e, 2 * salt + 1, n);
  if (dist == DIST_UNIFORM) return lerp(col.x, col.y, 1.0 - u);
  if (dist == DIST_LOG_UNIFORM) return exp(lerp(log(col.x), log(col.y), 1.0 - u));
  if (dist == DIST_CHOICE) return choices[uint(col.x) + min(uint((1.0 - u) * col.y), uint(col.y) - 1)];
  return clamp(col.x + col.y * gaussian(u, u2), col.z, col.w);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void sample(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.envs) return;
  if (env == 0) frame[0] += 1;
  const bool reset = pc.reset_all != 0 || reset_mask[env] != 0 || ended_a[env] != 0 || ended_b[env] != 0 ||
                    pending[env] != 0;
  pending[env] = 0;
  for (uint t = 0; t < pc.terms; ++t) {
    const uint4 term = terms[t].layout;
    const uint k = env * pc.terms + t, when = (term.z >> 8) & 0xff;
    bool now = pc.reset_all != 0 || (when == WHEN_RESET && reset);
    if (when == WHEN_INTERVAL) {
      uint steps = pc.reset_all != 0 ? 0 : counters[k] + 1;
      if (steps >= term.w) { now = true; steps = 0; }
      counters[k] = steps;
    }
    fresh[k] = now || reset ? 1 : 0;
    if (!now) continue;
    const uint n = draws[k];
    draws[k] = n + 1;
    for (uint c = 0; c < term.y; ++c) {
      const uint col = term.x + c;
      values[env * pc.columns + col] = draw(term.z & 0xff, columns[col], env, terms[t].salt.x + c, n);
    }
  }
}

float operate(float nominal, float v, uint op) { return op == OP_SCALE ? nominal * v : op == OP_ADD ? nominal + v : v; }
float3 operate3(float3 nominal, float3 v, uint op) {
  return float3(operate(nominal.x, v.x, op), operate(nominal.y, v.y, op), operate(nominal.z, v.z, op));
}

// this thread's target: false when it has nothing to write this frame
bool target(uint i, out uint4 ids, out uint param, out uint op, out float4 nominal, out float3 v) {
  ids = uint4(0, 0, 0, 0); param = 0; op = 0; nominal = float4(0, 0, 0, 0); v = float3(0, 0, 0);
  if (i >= pc.items) return false;
  ids = target_ids[i];
  if (fresh[ids.y * pc.terms + ids.x] == 0) return false;
  param = ids.w & 0xff;
  op = (ids.w >> 8) & 0xff;
  nominal = target_nominal[i];
  const uint4 term = terms[ids.x].layout;
  const uint base = ids.y * pc.columns + term.x;
  v = float3(values[base], term.y > 1 ? values[base + 1] : 0.0, term.y > 2 ? values[base + 2] : 0.0);
  return true;
}

RWStructuredBuffer<BodyModel> bodies;  // rigid.bodies
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_bodies(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  if (param == PARAM_MASS) {  // nominal: the authored inverse inertia (xyz) and inverse mass (w)
    const float m0 = 1.0 / n.w, m = operate(m0, v.x, op);
    bodies[ids.z].inv_inertia = n * (m0 / m);
  } else if (param == PARAM_DAMPING) {  // nominal.xy: linear, angular
    bodies[ids.z].damping.xy = float2(operate(n.x, v.x, op), operate(n.y, v.x, op));
  }
}

RWStructuredBuffer<ColliderModel> colliders;  // rigid.colliders
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_colliders(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  if (param == PARAM_FRICTION) colliders[ids.z].material.xy = float2(operate(n.x, v.x, op), operate(n.y, v.x, op));
  else if (param == PARAM_RESTITUTION) colliders[ids.z].material.z = operate(n.z, v.x, op);
}

RWStructuredBuffer<JointModel> joints;  // joint.model
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_joints(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  if (param == PARAM_JOINT_STIFFNESS) joints[ids.z].drive.x = operate(n.x, v.x, op);
  else if (param == PARAM_JOINT_DAMPING) joints[ids.z].drive.y = operate(n.y, v.x, op);
}

RWStructuredBuffer<ParticleObject> objects;  // particles.objects
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_objects(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  if (param == PARAM_FRICTION) objects[ids.z].material.y = operate(n.y, v.x, op);
  else if (param == PARAM_DAMPING) objects[ids.z].material.z = operate(n.z, v.x, op);
}

RWStructuredBuffer<float4> particle_positions;  // particles.positions: w the inverse mass
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_particles(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  // nominal: x the particle's authored inverse mass, y its object's mass; every particle scales alike
  particle_positions[ids.z].w = n.x * (n.y / operate(n.y, v.x, op));
}

RWStructuredBuffer<ParticleConstraint> family_constraints;  // particles.<family>_constraints
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_constraints(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  // nominal: xy the authored compliances in params.xy, zw 1 where that field is one (bend and
  // twist: both; the other families: y, x being the rest value)
  if (n.z != 0) family_constraints[ids.z].params.x = n.x / v.x;
  if (n.w != 0) family_constraints[ids.z].params.y = n.y / v.x;
}

RWStructuredBuffer<ParticleConstraint> tet_constraints;          // particles.tet_constraints
RWStructuredBuffer<ParticleConstraint> tet_initial_constraints;  // bodies with heat: coagulation scales these
// the tet's Lame parameters for the drawn modulus (nominal: mu, lambda, Young's modulus): both
// scale with it, the Poisson ratio kept
bool tet_params(uint i, out uint row, out float2 lame) {
  uint4 ids; uint param, op; float4 n; float3 v;
  row = 0; lame = float2(0, 0);
  if (!target(i, ids, param, op, n, v)) return false;
  row = ids.z;
  lame = n.xy * (operate(n.z, v.x, op) / n.z);
  return true;
}
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_tets(uint3 id : SV_DispatchThreadID) {
  uint row; float2 lame;
  if (tet_params(id.x, row, lame)) tet_constraints[row].params.yz = lame;
}
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_tets_heated(uint3 id : SV_DispatchThreadID) {
  uint row; float2 lame;
  if (!tet_params(id.x, row, lame)) return;
  tet_constraints[row].params.yz = lame;
  tet_initial_constraints[row].params.yz = lame;
}

RWStructuredBuffer<RenderableData> renderables;  // render.renderables
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_renderables(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  if (param == PARAM_TEXTURE) renderables[ids.z].maps.x = v.x < 0 ? 0 : uint(v.x + 0.5) + 1;  // index + 1, 0 none
  else renderables[ids.z].color.rgb = saturate(operate3(n.rgb, v, op));
}

RWStructuredBuffer<LightData> lights;  // render.lights
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_lights(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  // nominal: rgb the authored colour, w the intensity (the buffer holds their product)
  if (param == PARAM_LIGHT_INTENSITY) lights[ids.z].color.rgb = n.rgb * max(operate(n.w, v.x, op), 0.0);
  else lights[ids.z].color.rgb = saturate(operate3(n.rgb, v, op)) * n.w;
}

RWStructuredBuffer<EnvLighting> env_lighting;  // render.env_lighting, a row an env
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_environment(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  // row 3 env + k: k = 0 the sky, 1 the ground, 2 the environment map's scale (nominal: as authored)
  const uint env = ids.z / 3, k = ids.z % 3;
  const float3 c = n.rgb * max(v.x, 0.0);
  if (k == 0) env_lighting[env].sky.rgb = c;
  else if (k == 1) env_lighting[env].ground.rgb = c;
  else env_lighting[env].map_scale.rgb = c;
}

RWStructuredBuffer<float4> positions;  // transform.positions
RWStructuredBuffer<float4> rotations;  // transform.rotations
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_transforms(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  if (param == PARAM_CAMERA_POSITION) {
    positions[ids.z].xyz = operate3(n.xyz, v, op);
  } else {  // the authored orientation turned by the rotation vector v in its own frame
    const float angle = length(v);
    rotations[ids.z] = angle > 0 ? normalize(quat_mul(n, quat_axis_angle(v / angle, angle))) : n;
  }
}

RWStructuredBuffer<UltrasoundProbeData> probes;  // ultrasound<group>.probes
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void apply_probes(uint3 id : SV_DispatchThreadID) {
  uint4 ids; uint param, op; float4 n; float3 v;
  if (!target(id.x, ids, param, op, n, v)) return;
  probes[ids.z].display.y = operate(n.x, v.x, op);  // nominal.x: the authored gain (dB)
}

StructuredBuffer<uint2> layer_columns;  // per camera layer: x its env, y value column + 1 (0: no noise)
RWStructuredBuffer<float> depth;        // camera<group>.depth: (layers, H, W)
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void depth_noise(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.items) return;
  const uint2 lc = layer_columns[i / pc.pixels];
  const float z = depth[i];
  if (lc.y == 0 || !(z > 0)) return;  // no noise there, or nothing seen (depth 0)
  const float sigma = values[lc.x * pc.columns + lc.y - 1];
  const uint n = frame[0], pixel = i % pc.pixels;
  const float u1 = unit_hash(lc.x + pc.env_offset, 0x40000000u + 2 * pixel, n);
  const float u2 = unit_hash(lc.x + pc.env_offset, 0x40000001u + 2 * pixel, n);
  depth[i] = z + sigma * gaussian(u1, u2);
}
