// Contacts between particles (not fluid with fluid): overlapping spheres pushed apart, the overlap
// split by inverse mass. particle_neighbors averages them over the particle's contacts; so does
// particle_iterations, on the env's particles in group memory.

// whether particles i and j (phases ph, pj) push each other apart: of different objects, or of
// one self-colliding object
bool particles_collide(uint i, uint4 ph, uint j, uint4 pj) {
  return (pj.y != ph.y || ((ph.w & PARTICLE_SELF_COLLIDE) != 0 &&
                           // a strand's own neighbours along it overlap by construction
                           !(ph.x == PARTICLE_STRAND && abs(int(j) - int(i)) <= 2))) &&
         // a suture thread runs through the tissue it is sewn into
         !(((ph.w | pj.w) & PARTICLE_NO_SOFT_CONTACT) != 0 && (ph.x == PARTICLE_SOLID || pj.x == PARTICLE_SOLID));
}

// adds particle i's share of its overlap with j (r = xi - xj, reach the sum of their radii, wi and
// wj their inverse masses) to `contact`, and counts it
void add_contact(float3 r, float reach, float wi, float wj, inout float3 contact, inout float contacts) {
  const float d = length(r), w = wi + wj;
  if (d < reach && d > 1e-9 && w > 0) {
    contact += (reach - d) * (wi / w) * (r / d);
    contacts += 1;
  }
}
