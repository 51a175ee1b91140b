#include "gpu/spirv_reflect.h"

#include <gtest/gtest.h>

#include "gpu/embedded_shaders.h"
#include "gpu/shader_compiler.h"

using namespace cressim::gpu;

TEST(SpirvReflect, BindingsConstantsAndGroupSize) {
  const char* src = R"(
    struct P { uint n; float scale; float4 color; };
    [[vk::push_constant]] ConstantBuffer<P> pc;
    StructuredBuffer<float4> src_rows;
    RWStructuredBuffer<float> dst;
    [numthreads(32, 2, 1)] void main(uint3 id : SV_DispatchThreadID) {
      if (id.x < pc.n) dst[id.x] = src_rows[id.x].x * pc.scale + pc.color.y;
    })";
  ShaderReflection r = reflect_spirv(compile_hlsl(src, "test", "main"));
  ASSERT_EQ(r.bindings.size(), 2u);
  ASSERT_NE(r.find_binding("src_rows"), nullptr);
  EXPECT_FALSE(r.find_binding("src_rows")->writable);
  EXPECT_EQ(r.find_binding("src_rows")->stride, 16u);
  EXPECT_TRUE(r.find_binding("dst")->writable);
  EXPECT_EQ(r.find_binding("dst")->stride, 4u);
  ASSERT_NE(r.find_constant("scale"), nullptr);
  EXPECT_EQ(r.find_constant("scale")->offset, 4u);
  EXPECT_EQ(r.find_constant("scale")->kind, ScalarKind::FLOAT);
  EXPECT_EQ(r.find_constant("n")->kind, ScalarKind::UINT);
  EXPECT_EQ(r.find_constant("color")->components, 4u);
  EXPECT_EQ(r.push_constant_size, 32u);
  EXPECT_EQ(r.local_size[0], 32u);
  EXPECT_EQ(r.local_size[1], 2u);
}

TEST(SpirvReflect, GroupMemoryAtItsNaturalSize) {
  const char* src = R"(
    groupshared float4 a[100];
    groupshared uint b[7];
    groupshared int3 c[3];
    RWStructuredBuffer<float> o;
    [numthreads(64, 1, 1)] void main(uint3 t : SV_GroupThreadID) {
      a[t.x % 100] = float4(t.x, 0, 0, 0);
      b[t.x % 7] = t.x;
      c[t.x % 3] = int3(t.x, 1, 2);
      GroupMemoryBarrierWithGroupSync();
      o[t.x] = a[(t.x + 1) % 100].x + b[(t.x + 1) % 7] + c[(t.x + 1) % 3].y;
    })";
  EXPECT_EQ(reflect_spirv(compile_hlsl(src, "shared", "main")).workgroup_bytes, 100u * 16 + 7 * 4 + 3 * 12);
}

// the one-workgroup-per-env builds hold an env's particles in group memory: each must fit the
// 32 KB lavapipe offers (NVIDIA 48 KB), or the engine would fall back to the per-colour passes there
TEST(SpirvReflect, EveryOneWorkgroupBuildFitsLavapipesGroupMemory) {
  int blocks = 0;
  for (const auto& name : embedded_shader_names())
    if (name.find(".block") != std::string::npos) {
      const uint32_t bytes = reflect_spirv(embedded_shader(name)).workgroup_bytes;
      EXPECT_GT(bytes, 0u) << name;
      EXPECT_LE(bytes, 32768u) << name;
      ++blocks;
    }
  EXPECT_GT(blocks, 0);
}

TEST(SpirvReflect, ConstantBuffersAreRefusedWithAHint) {
  const char* src = "cbuffer Params { float k; };\nRWStructuredBuffer<float> o;\n"
                    "[numthreads(1,1,1)] void main() { o[0] = k; }";
  EXPECT_THROW(reflect_spirv(compile_hlsl(src, "cb", "main")), std::runtime_error);
}

TEST(SpirvReflect, BuiltInShadersKeepTheirNames) {
  ShaderReflection r = reflect_spirv(embedded_shader("scene/reset_envs"));
  for (const char* n : {"entity_env", "reset_mask", "initial_positions", "positions"})
    EXPECT_NE(r.find_binding(n), nullptr) << n;
  EXPECT_NE(r.find_constant("row_count"), nullptr);
}

TEST(ShaderCompiler, ErrorsCarryFileAndLine) {
  try {
    compile_hlsl("[numthreads(1,1,1)]\nvoid main() {\n  nope();\n}\n", "file.hlsl", "main");
    FAIL() << "compiled";
  } catch (const ShaderCompileError& e) {
    EXPECT_NE(std::string(e.what()).find("file.hlsl:3:"), std::string::npos) << e.what();
  }
}
