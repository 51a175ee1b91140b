// Particles held rigidly by an attachment slot are anchors to the chain solves along a strand
// (particle_stretch, particle_stretch_shear): weight 0, the attachment pass puts them where their
// body says. The chain's env's slots are scanned once per chain (the first few held ones kept).
StructuredBuffer<uint4> phases;
StructuredBuffer<ParticleAttachment> attachments;

static const uint MAX_ANCHORS = 8;
static uint anchors[MAX_ANCHORS];
static uint anchor_count;

void find_anchors(uint particle) {
  anchor_count = 0;  // set here: initialisers of static globals are not run per invocation everywhere
  if (pc.has_rigid == 0 || pc.attachment_count == 0) return;
  const uint per_env = pc.attachment_count / pc.env_count, env = phases[particle].z;
  for (uint a = env * per_env; a < (env + 1) * per_env && anchor_count < MAX_ANCHORS; ++a) {
    const ParticleAttachment at = attachments[a];
    if (at.ids.z != ATTACH_FREE && at.local.w == 0) anchors[anchor_count++] = at.ids.x;
  }
}

// the particle's inverse mass in the chain solve: 0 when held
float weight(uint p, float w) {
  for (uint k = 0; k < anchor_count; ++k)
    if (anchors[k] == p) return 0;
  return w;
}
