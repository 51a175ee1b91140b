// Shared by the C++ tests: one validated context per test, failing on any validation message.
#pragma once
#include <gtest/gtest.h>

#include "gpu/context.h"

namespace cressim::test_support {

inline std::shared_ptr<gpu::Context> validated_context() {
  gpu::ContextOptions o;
  o.validation = true;
  return gpu::create_context(o);
}

inline void expect_no_validation_messages(gpu::Context& ctx) {
  std::lock_guard<std::mutex> lock(ctx.messages_mutex);
  for (auto& m : ctx.validation_messages) ADD_FAILURE() << m;
}

}  // namespace cressim::test_support
