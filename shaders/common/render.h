// Layouts shared by the batched rasterizer (engine/render) and shaders/render.
#ifndef CRESSIM_RENDER_H
#define CRESSIM_RENDER_H
#include "cressim/types.h"

CRESSIM_SHADER_BEGIN

struct RenderableData {
  uint4 ids;       // x entity row, y mesh, z segmentation id, w env
  float4 color;    // base colour, linear RGBA
  float4 material; // x metallic, y roughness
};

// Cameras look along their entity's +z with x right and y down (the optical frame of ROS and
// OpenCV): pixel (u, v) = (fx x / z + cx, fy y / z + cy); depth is z, in metres.
struct CameraData {
  float4 intrinsics;  // fx, fy, cx, cy (pixels)
  float4 clip;        // near, far, width, height
  uint4 ids;          // x entity row, y env, z group, w layer
};

struct EnvLight {
  float4 direction;  // xyz: direction the light travels (world), w: ambient
  float4 color;      // rgb radiance, w unused
};

CRESSIM_SHADER_END
#endif
