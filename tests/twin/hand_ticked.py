"""A twin node in the test's process, ticked by the test, and a client node beside it over DDS."""
from contextlib import contextmanager


def homed(node):
    """The node's arms (env 0 enabled and homed); the node's timer stopped: the test ticks it."""
    node.timer.cancel()
    arms = node.arms
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    settled(node)
    return arms


def settled(node):
    while node.arms.states[0].is_busy:
        node._tick()


@contextmanager
def client_beside(node, name: str):
    """(client, until): a client node in the node's context, and `until(done, what, ticks=300)`,
    which ticks the node and spins both until done() holds (an AssertionError naming `what` if it
    never does: counted in ticks, not seconds)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    client = rclpy.create_node(name, context=node.context)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    executor.add_node(client)

    def until(done, what, ticks=300):
        for _ in range(ticks):
            if done():
                return
            node._tick()
            executor.spin_once(timeout_sec=0.02)
        raise AssertionError(what)

    try:
        yield client, until
    finally:
        executor.shutdown()
        client.destroy_node()
