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
