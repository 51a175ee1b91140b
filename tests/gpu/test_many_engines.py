"""Many engines, one after the other, in one process (a notebook, a sweep, a test suite). The
NVIDIA driver refused vkCreateInstance after 30 instance create/destroy cycles in a process;
engines share one VkInstance now (engine/gpu/context.cpp). On lavapipe this checks that the
shared instance outlives engines and that each engine still gets its own working device."""
import cressim


def test_forty_engines_in_a_row():
    for i in range(40):
        world = cressim.World(cressim.SceneLayout(2))
        world.create_entity(env=i % 2).add(cressim.Transform(position=(float(i), 0, 0)))
        engine = cressim.Engine(world)
        engine.prepare()
        engine.upload_world()
        engine.step_physics()
        engine.end_frame()
        assert engine.buffer("transform.positions").read()[0][0] == float(i)
        assert engine.validation_messages == []
        del engine, world
