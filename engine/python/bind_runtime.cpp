#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fstream>
#include <sstream>

#include "compute/cuda_interop.h"
#include "python/bindings.h"
#include "runtime/engine.h"

namespace py = pybind11;

namespace cressim::python {
namespace {

using runtime::Engine;

template <class T>
py::array_t<T> to_numpy(const std::vector<T>& v) {
  py::array_t<T> a(py::ssize_t(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

py::dict device_dict(const gpu::Context& c) {
  py::dict d;
  d["index"] = c.info.index;
  d["name"] = c.info.name;
  d["type"] = c.info.type;
  d["vulkan"] = std::to_string(VK_API_VERSION_MAJOR(c.info.api_version)) + "." +
                std::to_string(VK_API_VERSION_MINOR(c.info.api_version)) + "." +
                std::to_string(VK_API_VERSION_PATCH(c.info.api_version));
  d["driver"] = c.info.driver;
  d["uuid"] = c.info.uuid;
  d["subgroup_size"] = c.subgroup_size;
  d["max_storage_buffer_range"] = c.properties.limits.maxStorageBufferRange;
  d["max_compute_work_group_count"] = std::vector<uint32_t>(c.properties.limits.maxComputeWorkGroupCount,
                                                            c.properties.limits.maxComputeWorkGroupCount + 3);
  d["max_compute_work_group_invocations"] = c.properties.limits.maxComputeWorkGroupInvocations;
  d["timestamp_period_ns"] = c.properties.limits.timestampPeriod;
  d["unified_memory"] = c.unified_memory;
  d["external_memory_fd"] = c.external_memory_fd;
  d["external_semaphore_fd"] = c.external_semaphore_fd;
  d["validation"] = c.validation;
  return d;
}

gpu::ContextOptions options(py::object validation, py::object device) {
  auto o = gpu::options_from_environment();
  if (!validation.is_none()) o.validation = validation.cast<bool>();
  if (!device.is_none()) o.device = py::str(device).cast<std::string>();
  return o;
}

}  // namespace

void bind_physics_settings(py::module_& m) {
  using physics::PhysicsSettings;
  py::class_<PhysicsSettings>(m, "PhysicsSettings")
      .def(py::init([](float dt, uint32_t substeps, uint32_t iterations, std::array<float, 3> gravity,
                       uint32_t max_contacts, float max_speed, float max_penetration, uint32_t particle_iterations,
                       uint32_t max_attachments, uint32_t particle_contact_iterations, std::string particle_solver,
                       uint32_t particle_substeps) {
             PhysicsSettings s{dt, substeps, iterations, gravity, max_contacts, max_speed, max_penetration,
                               particle_iterations, max_attachments, particle_contact_iterations,
                               std::move(particle_solver), particle_substeps};
             s.validate();
             return s;
           }),
           py::kw_only(), py::arg("dt") = 1.0f / 60.0f, py::arg("substeps") = 4u, py::arg("iterations") = 1u,
           py::arg("gravity") = std::array<float, 3>{0, 0, -9.81f}, py::arg("max_contacts_per_env") = 64u,
           py::arg("max_speed") = 100.f, py::arg("max_penetration") = 0.25f, py::arg("particle_iterations") = 4u,
           py::arg("max_particle_attachments_per_env") = 4u, py::arg("particle_contact_iterations") = 0u,
           py::arg("particle_solver") = "auto", py::arg("particle_substeps") = 0u)
      .def_readwrite("dt", &PhysicsSettings::dt)
      .def_readwrite("substeps", &PhysicsSettings::substeps)
      .def_readwrite("iterations", &PhysicsSettings::iterations)
      .def_readwrite("gravity", &PhysicsSettings::gravity)
      .def_readwrite("max_contacts_per_env", &PhysicsSettings::max_contacts_per_env)
      .def_readwrite("max_speed", &PhysicsSettings::max_speed)
      .def_readwrite("max_penetration", &PhysicsSettings::max_penetration)
      .def_readwrite("particle_iterations", &PhysicsSettings::particle_iterations)
      .def_readwrite("max_particle_attachments_per_env", &PhysicsSettings::max_particle_attachments_per_env)
      .def_readwrite("particle_contact_iterations", &PhysicsSettings::particle_contact_iterations)
      .def_readwrite("particle_solver", &PhysicsSettings::particle_solver)
      .def_readwrite("particle_substeps", &PhysicsSettings::particle_substeps)
      .def("__repr__", [](const PhysicsSettings& s) {
        return py::str("PhysicsSettings(dt={}, substeps={}, iterations={}, gravity={})")
            .format(s.dt, s.substeps, s.iterations, py::cast(s.gravity));
      });
}

void bind_runtime(py::module_& m) {
  bind_physics_settings(m);
  m.def("list_devices", [] {
    py::list out;
    for (auto& d : gpu::list_devices()) {
      py::dict e;
      e["index"] = d.index;
      e["name"] = d.name;
      e["type"] = d.type;
      e["vulkan"] = std::to_string(VK_API_VERSION_MAJOR(d.api_version)) + "." +
                    std::to_string(VK_API_VERSION_MINOR(d.api_version));
      e["driver"] = d.driver;
      e["uuid"] = d.uuid;
      out.append(e);
    }
    return out;
  });

  py::class_<Engine>(m, "Engine")
      .def(py::init([](std::shared_ptr<scene::World> w, py::object validation, py::object device) {
             return std::make_unique<Engine>(std::move(w), options(validation, device));
           }),
           py::arg("world"), py::kw_only(), py::arg("validation") = py::none(), py::arg("device") = py::none())
      .def_property_readonly("device", [](const Engine& e) { return device_dict(*e.context()); })
      .def_property_readonly("validation_enabled", [](const Engine& e) { return e.context()->validation; })
      .def_property_readonly("validation_messages", &Engine::validation_messages)
      .def_property_readonly("world", [](Engine& e) { return e.world(); })
      .def("prepare", &Engine::prepare, py::call_guard<py::gil_scoped_release>())
      .def("upload_world", &Engine::upload_world, py::call_guard<py::gil_scoped_release>())
      .def("step_physics", &Engine::step_physics)
      .def("reset_flagged_envs", &Engine::reset_flagged_envs,
           "Adds a reset of the envs flagged in env.reset_mask at this point of the frame.")
      .def_property("physics", &Engine::physics_settings, &Engine::set_physics_settings,
                    "PhysicsSettings; assign a changed copy to apply it from the next frame.")
      .def("step_visual_sensors", &Engine::step_visual_sensors)
      .def("step_simulation_sensors", &Engine::step_simulation_sensors)
      .def("execute_compute_pass", &Engine::execute_compute_pass, py::arg("compute_pass"))
      .def("end_frame", &Engine::end_frame, py::call_guard<py::gil_scoped_release>())
      .def("create_shared_buffer",
           [](Engine& e, const std::string& name, py::object shape, py::object dtype) {
             std::vector<int64_t> s;
             if (py::isinstance<py::int_>(shape)) s.push_back(shape.cast<int64_t>());
             else s = shape.cast<std::vector<int64_t>>();
             std::string dt = py::str(py::module_::import("numpy").attr("dtype")(dtype).attr("name"));
             return e.create_shared_buffer(name, s, compute::parse_dtype(dt));
           },
           py::arg("name"), py::arg("shape"), py::arg("dtype") = "float32")
      .def("create_compute_pass",
           [](Engine& e, const std::string& source, const std::string& name, const std::string& entry,
              py::dict bindings, py::object dispatch, py::object threads, py::dict constants,
              std::vector<std::string> internal_writes) {
             compute::PassSpec spec;
             spec.internal_writes = {internal_writes.begin(), internal_writes.end()};
             spec.name = name;
             spec.source = source;
             spec.entry = entry;
             std::map<std::string, std::string> keys;
             for (auto [k, v] : bindings) {
               if (py::isinstance<compute::TypedBuffer>(v)) spec.bindings[py::str(k)] = v.cast<std::shared_ptr<compute::TypedBuffer>>();
               else if (py::isinstance<py::str>(v)) keys[py::str(k)] = py::str(v);
               else throw py::type_error("binding '" + std::string(py::str(k)) + "' must be a Buffer or a key string");
             }
             auto three = [](py::object o) {
               std::array<uint64_t, 3> a{1, 1, 1};
               if (py::isinstance<py::int_>(o)) { a[0] = o.cast<uint64_t>(); return a; }
               auto v = o.cast<std::vector<uint64_t>>();
               if (v.empty() || v.size() > 3) throw py::value_error("dispatch/threads: give 1 to 3 numbers");
               std::copy(v.begin(), v.end(), a.begin());
               return a;
             };
             if (dispatch.is_none() == threads.is_none())
               throw py::value_error("create_compute_pass '" + name + "': give exactly one of dispatch=(groups) or threads=n");
             if (!threads.is_none()) spec.threads = three(threads);
             else { auto g = three(dispatch); spec.groups = {uint32_t(g[0]), uint32_t(g[1]), uint32_t(g[2])}; }
             std::shared_ptr<compute::ComputePass> pass;
             {
               py::gil_scoped_release release;
               pass = e.create_compute_pass(spec, keys);
             }
             py::object p = py::cast(pass);
             for (auto [k, v] : constants) p.attr("set_constant")(k, v);
             return pass;
           },
           py::arg("source"), py::kw_only(), py::arg("name"), py::arg("entry") = "main",
           py::arg("bindings") = py::dict(), py::arg("dispatch") = py::none(), py::arg("threads") = py::none(),
           py::arg("constants") = py::dict(), py::arg("internal_writes") = std::vector<std::string>{})
      .def("buffer", &Engine::lookup, py::arg("key"), "A shared buffer by name or an internal buffer by key.")
      .def_property_readonly("internal_keys", &Engine::internal_keys)
      .def_property_readonly("shared_buffers", &Engine::shared_names)
      .def("reset_envs", &Engine::reset_envs, py::arg("envs"))
      .def_property_readonly("mapping", [](const Engine& e) {
        const auto& m = e.mapping();
        py::dict d;
        d["entity_id"] = to_numpy(m.row_entity);
        d["env_index"] = to_numpy(m.row_env);
        d["entity_row"] = to_numpy(m.entity_row);
        d["env_offset"] = to_numpy(m.env_offset);
        d["env_count"] = to_numpy(m.env_count);
        return d;
      })
      .def_property_readonly("cameras", [](const Engine& e) {
        py::dict d;
        std::vector<uint32_t> entity, env, group, layer;
        if (e.renderer()) {
          const auto& m = e.renderer()->model();
          entity = m.camera_entity;
          for (auto& c : m.cameras) env.push_back(c.ids.y), group.push_back(c.ids.z), layer.push_back(c.ids.w);
        }
        d["entity"] = to_numpy(entity);
        d["env"] = to_numpy(env);
        d["group"] = to_numpy(group);
        d["layer"] = to_numpy(layer);
        return d;
      }, "Each camera's entity, env, and where its images are: camera{group}.rgb[layer] etc.")
      .def_property_readonly("ultrasound_probes", [](const Engine& e) {
        py::dict d;
        std::vector<uint32_t> entity, env, group, layer, lines, samples, width, height;
        size_t scatterers = 0;
        if (e.ultrasound()) {
          const auto& m = e.ultrasound()->model();
          entity = m.probe_entity, group = m.probe_group;
          for (size_t i = 0; i < m.probes.size(); ++i) {
            const auto& g = m.groups[m.probe_group[i]];
            env.push_back(m.probes[i].ids.y), layer.push_back(m.probes[i].ids.w);
            lines.push_back(g.lines), samples.push_back(g.samples);
            width.push_back(g.width), height.push_back(g.height);
          }
          scatterers = e.ultrasound()->scatterers();
          d["tets"] = m.tets.size();  // soft tissue tets carrying scatterers
        }
        d["entity"] = to_numpy(entity);
        d["env"] = to_numpy(env);
        d["group"] = to_numpy(group);
        d["layer"] = to_numpy(layer);
        d["lines"] = to_numpy(lines), d["samples"] = to_numpy(samples);
        d["width"] = to_numpy(width), d["height"] = to_numpy(height);
        d["scatterers"] = scatterers;
        return d;
      }, "Each ultrasound probe's entity, env, and where its outputs are: ultrasound{group}.image[layer] "
         "(also .image_u8, .iq, .rf), with that group's scanlines, IQ samples per line and image size; the "
         "scatterer count over all envs (and the soft-tissue tets carrying them).")
      .def_property_readonly("health_events", &Engine::health_events,
                             "Envs flagged unhealthy (NaN/Inf, speed, penetration) and reset since upload_world().")
      .def_property_readonly("prepared", &Engine::prepared)
      .def_property_readonly("uploaded", &Engine::uploaded)
      .def_property_readonly("frame_count", &Engine::frame_count)
      .def_property_readonly("recorded_frames", &Engine::recorded_frames)
      .def_property_readonly("submits", &Engine::submits)
      .def_property("profiling", &Engine::profiling, &Engine::set_profiling)
      .def("set_cuda_stream", &Engine::set_cuda_stream, py::arg("stream"), py::arg("host_sync") = false)
      .def_property("cuda_stream", &Engine::cuda_stream, [](Engine& e, uintptr_t s) { e.set_cuda_stream(s); },
                    "A CUDA stream (torch.cuda.current_stream().cuda_stream): every frame waits on the GPU "
                    "for the work queued on it before (timeline-semaphore sync). 0: none.")
      .def_property_readonly("cuda_interop", [](const Engine& e) {
        const std::string why = compute::cuda_unavailable_reason(*e.context());
        py::dict d;
        d["available"] = why.empty();
        d["reason"] = why;
        return d;
      })
      .def_property_readonly("last_timings", &Engine::last_timings)
      .def_property("profile_passes", &Engine::profile_passes, &Engine::set_profile_passes,
                    "With profiling on, also time every compute pass inside the frame's ops "
                    "(last_pass_timings). The extra timestamps cost a little GPU time themselves.")
      .def_property_readonly("last_pass_timings", &Engine::last_pass_timings,
                             "(op, pass, ms) of the last frame profiled with profile_passes, in recorded order; "
                             "'(rest)' is an op's work after its last pass (draws, copies, barriers).");
}

}  // namespace cressim::python
