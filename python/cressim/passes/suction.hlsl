// Suction: flags the active fluid particles within `radius` of `tip` for removal
// (control.particle_remove, applied at the next step's start), in env `env` or, with env
// 0xffffffff, in every env (each env's tip at the same coordinates). Threads: the particles.
struct Params { uint count; uint env; float radius; float pad; float4 tip; };
[[vk::push_constant]] ConstantBuffer<Params> pc;
StructuredBuffer<float4> positions;
StructuredBuffer<uint4> phases;
RWStructuredBuffer<uint> remove;

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.count) return;
  const uint4 ph = phases[i];
  const bool here = pc.env == 0xffffffffu || ph.z == pc.env;
  if (here && ph.x == 2 && (ph.w & 1) != 0 && length(positions[i].xyz - pc.tip.xyz) < pc.radius) remove[i] = 1;
}
