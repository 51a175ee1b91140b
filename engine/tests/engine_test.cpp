#include "runtime/engine.h"

#include <gtest/gtest.h>

using namespace cressim;

namespace {
std::shared_ptr<runtime::Engine> make_engine(uint32_t envs) {
  auto world = std::make_shared<scene::World>(scene::SceneLayout{envs});
  for (uint32_t e = 0; e < envs; ++e) world->add(world->create_entity(e), scene::Transform{{float(e), 0, 0}});
  gpu::ContextOptions o;
  o.validation = true;
  auto engine = std::make_shared<runtime::Engine>(world, o);
  engine->prepare();
  engine->upload_world();
  return engine;
}
}  // namespace

TEST(Engine, SteadyFrameIsOneRecordingAndOneSubmitPerStep) {
  auto engine = make_engine(4);
  auto acc = engine->create_shared_buffer("acc", {4}, compute::DType::FLOAT32);
  compute::PassSpec spec;
  spec.name = "accumulate";
  spec.source = "StructuredBuffer<float4> p; RWStructuredBuffer<float> acc;\n"
                "[numthreads(64,1,1)] void main(uint3 id : SV_DispatchThreadID) { if (id.x < 4) acc[id.x] += p[id.x].x; }";
  spec.threads = {4, 1, 1};
  auto pass = engine->create_compute_pass(spec, {{"p", "transform.positions"}, {"acc", "acc"}});
  for (int i = 0; i < 5; ++i) {
    engine->step_physics();
    engine->execute_compute_pass(pass);
    engine->end_frame();
  }
  EXPECT_EQ(engine->recorded_frames(), 1u);
  EXPECT_EQ(engine->submits(), 5u);
  float out[4];
  gpu::readback(*engine->context(), acc->storage->buffer, out, sizeof(out));
  for (int e = 0; e < 4; ++e) EXPECT_FLOAT_EQ(out[e], 5.f * e);
  EXPECT_TRUE(engine->validation_messages().empty());
}

TEST(Engine, TopologyChangeAfterUploadIsRefused) {
  auto engine = make_engine(2);
  engine->world()->create_entity(1);
  EXPECT_THROW(engine->step_physics(), runtime::TopologyError);
  engine->prepare();
  engine->upload_world();
  EXPECT_NO_THROW(engine->end_frame());
}
