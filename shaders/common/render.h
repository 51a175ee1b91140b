// Layouts shared by the batched rasterizer (engine/render) and shaders/render.
#ifndef CRESSIM_RENDER_H
#define CRESSIM_RENDER_H
#include "cressim/types.h"

CRESSIM_SHADER_BEGIN

static const uint RENDER_NO_ROW = 0xffffffffu;  // a light without an entity (the default light)
static const uint LIGHT_DIRECTIONAL = 1, LIGHT_POINT = 2, LIGHT_SPOT = 3;  // LightData.ids.y; 0: none

struct RenderableData {
  uint4 ids;       // x entity row, y mesh, z segmentation id, w env
  float4 color;    // base colour, linear RGBA
  float4 material; // x metallic, y roughness, w normal_scale (z: a particle object's radius)
  uint4 maps;      // x texture index + 1 (0: none), y RENDER_FLAT_NORMALS | (normal map index + 1)
                   // << RENDER_NORMAL_MAP_SHIFT, z added to the mesh's vertex ids, w RENDER_WORLD_VERTICES
};

// RenderableData.maps.y: normals from the triangle (meshes whose vertices come from a buffer),
// and the normal map above that bit
static const uint RENDER_FLAT_NORMALS = 1, RENDER_NORMAL_MAP_SHIFT = 1;

// RenderableData.maps.w: the vertices are world positions written each frame (particle
// surfaces and strand tubes): no entity transform, and no bounding sphere to cull by.
static const uint RENDER_WORLD_VERTICES = 1;

// How the particle vertex pass makes each generated vertex (render.particle_vertices): x kind
// (low 4 bits), ring slot (bits 4-11) and ring size (bits 12-19) of a tube vertex; y particle;
// surface: z first triangle in render.particle_adjacency, w count; tube: z, w the strand
// segments whose frames it averages; cap centre: z the end segment, w 0 at the start, 1 at the end.
static const uint PARTICLE_VERTEX_NONE = 0, PARTICLE_VERTEX_SURFACE = 1, PARTICLE_VERTEX_TUBE = 2,
                  PARTICLE_VERTEX_CAP = 3;

// Cameras look along their entity's +z with x right and y down (the optical frame of ROS and
// OpenCV): pixel (u, v) = (fx x / z + cx, fy y / z + cy); depth is z, in metres.
struct CameraData {
  float4 intrinsics;  // fx, fy, cx, cy (pixels)
  float4 clip;        // near, far, width, height
  uint4 ids;          // x entity row, y env, z group, w layer
};

// One light slot (max_lights_per_env per env). Directional lights travel along the entity's
// +z, spots point along it; the pose is read from the transform rows every frame.
struct LightData {
  uint4 ids;         // x entity row (RENDER_NO_ROW: `direction` below), y kind (0: empty slot)
  float4 color;      // rgb: colour x intensity; w: range (0: unlimited)
  float4 cone;       // x cos(inner), y cos(outer) half-angles
  float4 direction;  // travel direction of a light without an entity
};

// Per env: ambient hemisphere (or environment map) and the shadow map of its first shadowed directional light.
struct EnvLighting {
  float4 sky;     // rgb from +z
  float4 ground;  // rgb from -z
  uint4 ids;      // x first light slot, y light slots, z shadow map index + 1 (0: none), w shadow light row
  float4 shadow;  // x half-size (m), y half depth range (m), z resolution (texels), w unused
  uint4 map;         // environment map: x texture index + 1 (0: none, the hemisphere), y its slot in render.ibl_*
  float4 map_scale;  // rgb: radiance per linear texel value (EnvironmentLight.intensity)
};

struct TextureInfo {
  uint4 extent;  // x first texel in render.texels, y width, z height, w mip levels (each after the last)
};

CRESSIM_SHADER_END
#endif
