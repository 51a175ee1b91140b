#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "python/bindings.h"
#include "scene/world.h"

namespace py = pybind11;

namespace cressim::python {
namespace {

// A handle to one entity; the world stays alive while handles exist.
struct Entity {
  std::shared_ptr<scene::World> world;
  scene::EntityId id;
};

}  // namespace

void bind_scene(py::module_& m) {
  py::class_<scene::SceneLayout>(m, "SceneLayout")
      .def(py::init([](uint32_t num_envs, uint32_t r, uint32_t l, uint32_t c) {
             scene::SceneLayout s{num_envs, r, l, c};
             s.validate();
             return s;
           }),
           py::arg("num_envs"), py::kw_only(), py::arg("max_renderables_per_env") = 16,
           py::arg("max_lights_per_env") = 4, py::arg("max_cameras_per_env") = 4)
      .def_readonly("num_envs", &scene::SceneLayout::num_envs)
      .def_readonly("max_renderables_per_env", &scene::SceneLayout::max_renderables_per_env)
      .def_readonly("max_lights_per_env", &scene::SceneLayout::max_lights_per_env)
      .def_readonly("max_cameras_per_env", &scene::SceneLayout::max_cameras_per_env)
      .def("__repr__", [](const scene::SceneLayout& s) {
        return "SceneLayout(num_envs=" + std::to_string(s.num_envs) + ", max_renderables_per_env=" +
               std::to_string(s.max_renderables_per_env) + ", max_lights_per_env=" +
               std::to_string(s.max_lights_per_env) + ", max_cameras_per_env=" +
               std::to_string(s.max_cameras_per_env) + ")";
      });

  py::class_<scene::Transform>(m, "Transform")
      .def(py::init([](std::array<float, 3> p, std::array<float, 4> r, std::array<float, 3> s) {
             return scene::Transform{p, r, s};
           }),
           py::kw_only(), py::arg("position") = std::array<float, 3>{0, 0, 0},
           py::arg("rotation") = std::array<float, 4>{0, 0, 0, 1}, py::arg("scale") = std::array<float, 3>{1, 1, 1},
           "Pose of an entity; rotation is a quaternion (x, y, z, w).")
      .def_readwrite("position", &scene::Transform::position)
      .def_readwrite("rotation", &scene::Transform::rotation)
      .def_readwrite("scale", &scene::Transform::scale)
      .def("__repr__", [](const scene::Transform& t) {
        return py::str("Transform(position={}, rotation={}, scale={})")
            .format(py::cast(t.position), py::cast(t.rotation), py::cast(t.scale));
      });

  py::class_<Entity>(m, "Entity")
      .def_property_readonly("id", [](const Entity& e) { return e.id; })
      .def_property_readonly("env", [](const Entity& e) { return e.world->env_of(e.id); })
      .def_property_readonly("name", [](const Entity& e) { return e.world->name_of(e.id); })
      .def("add", [](Entity& e, const scene::Transform& t) { e.world->add(e.id, t); return e; }, py::arg("component"),
           "Attaches a component (a topology change: prepare() again if already uploaded).")
      .def("has", [](const Entity& e, py::object type) {
        if (type.is(py::type::of<scene::Transform>())) return e.world->has<scene::Transform>(e.id);
        throw py::type_error("unknown component type");
      })
      .def_property(
          "transform", [](const Entity& e) { return e.world->get<scene::Transform>(e.id); },
          [](Entity& e, const scene::Transform& t) { e.world->set(e.id, t); },
          "Reading copies; assigning changes the value only (uploaded before the next frame).")
      .def("__repr__", [](const Entity& e) { return "<Entity " + e.world->describe(e.id) + ">"; });

  py::class_<scene::World, std::shared_ptr<scene::World>>(m, "World")
      .def(py::init<scene::SceneLayout>(), py::arg("layout"))
      .def_property_readonly("layout", &scene::World::layout)
      .def("create_entity",
           [](std::shared_ptr<scene::World> w, uint32_t env, const std::string& name) {
             return Entity{w, w->create_entity(env, name)};
           },
           py::arg("env"), py::arg("name") = "")
      .def("entity", [](std::shared_ptr<scene::World> w, scene::EntityId id) {
        w->env_of(id);  // validates
        return Entity{w, id};
      })
      .def_property_readonly("entity_count", &scene::World::entity_count)
      .def_property_readonly("topology_version", &scene::World::topology_version);
}

}  // namespace cressim::python
