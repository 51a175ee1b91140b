// A custom compute pass (paper section V): HLSL compiled at run time, its bindings resolved
// by name to typed buffers, its push constants set by name, dispatched inside the frame.
#pragma once
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <set>
#include <string>
#include <vector>

#include "compute/typed_buffer.h"
#include "gpu/pipeline.h"

namespace cressim::compute {

// A binding names a buffer that does not exist, or a shader binding is left without one.
struct BindingError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

struct PassSpec {
  std::string name;    // for messages and timings
  std::string source;  // HLSL text
  std::string entry = "main";
  std::map<std::string, std::shared_ptr<TypedBuffer>> bindings;  // HLSL name -> buffer
  std::array<uint32_t, 3> groups{0, 0, 0};   // thread groups; or
  std::array<uint64_t, 3> threads{0, 0, 0};  // threads, rounded up to whole groups
  // internal buffers (keys) this pass may write, named one by one: domain randomization writes
  // the model buffers (masses, frictions, colours) that custom passes otherwise only read
  std::set<std::string> internal_writes;
};

struct ComputePass {
  std::string name;
  uint64_t uid = 0;  // unique per process: recorded frames key on it, never on an address
  std::shared_ptr<gpu::Context> ctx;
  gpu::ComputePipeline pipeline;
  std::map<std::string, std::shared_ptr<TypedBuffer>> bindings;
  std::vector<uint8_t> constants;
  std::array<uint32_t, 3> groups{1, 1, 1};
  uint64_t version = 0;  // bumps when constants or dispatch change, so the frame re-records

  ~ComputePass();
  void set_constant(const std::string& name, double value);
  void set_constant_bits(const std::string& name, const void* data, size_t size);
  void set_groups(std::array<uint32_t, 3> g) { groups = g; ++version; }
  void set_threads(std::array<uint64_t, 3> threads);
  void record(VkCommandBuffer cmd) const;
};

std::shared_ptr<ComputePass> create_compute_pass(std::shared_ptr<gpu::Context> ctx, const PassSpec& spec);

// The same, for a shader compiled into the library (shaders/<name>.comp.hlsl).
std::shared_ptr<ComputePass> create_builtin_pass(std::shared_ptr<gpu::Context> ctx, const std::string& shader,
                                                 std::map<std::string, std::shared_ptr<TypedBuffer>> bindings,
                                                 bool allow_internal_writes = true);

}  // namespace cressim::compute
