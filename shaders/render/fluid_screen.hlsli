// Screen-space fluid (fluid_splat, fluid_smooth, fluid_shade): per camera group, buffers of
// (layers, H, W) pixels. fluid_depth holds the nearest sphere's depth as float bits (positive
// floats order like their bits, so an atomic min finds it; 0xffffffff: no fluid), fluid_thickness
// the summed chord lengths in micrometres of spheres in front of the scene.
static const uint FLUID_NONE = 0xffffffffu;
static const float FLUID_THICKNESS_UNIT = 1e-6;  // metres per count
// impostors a little larger than the physics radius (spacing is 2 r) close the gaps between them
static const float FLUID_DRAW_SCALE = 1.25;

struct FluidParams {
  uint width;
  uint height;
  uint layers;
  uint particle_count;
};
