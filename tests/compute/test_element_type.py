"""A custom pass's buffers are checked against the element type the HLSL declares
(engine/compute/element_type.cpp): float data for float elements, integers for integer ones,
and rows that hold whole elements, so a pass never reads past a buffer's end."""
import pytest

import cressim


def read_as(element: str) -> str:
    first = "v[0].x" if element[-1].isdigit() else "v[0]"
    return (f"StructuredBuffer<{element}> v; RWStructuredBuffer<uint> o;\n"
            f"[numthreads(1, 1, 1)] void main() {{ o[0] = uint({first}); }}")


STRUCT = """struct P { float3 p; uint k; };
StructuredBuffer<P> v; RWStructuredBuffer<uint> o;
[numthreads(1, 1, 1)] void main() { o[0] = v[0].k + uint(v[0].p.x); }"""


@pytest.fixture
def engine(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):
        world.create_entity(env=env).add(cressim.Transform())
    e = make_engine(world)
    e.prepare()
    e.upload_world()
    e.create_shared_buffer("o", 1, "uint32")
    return e


def bind(engine, source, buffer):
    return engine.create_compute_pass(source, name="p", threads=1, bindings={"v": buffer, "o": "o"})


def test_a_flat_float_buffer_bound_as_float4_is_refused(engine):
    engine.create_shared_buffer("flat", 8, "float32")
    with pytest.raises(cressim.BindingError, match=r"pass 'p', binding 'v': the shader reads float4 elements "
                                                   r"\(16 bytes each\), but it is bound to 'flat' \(8,\) float32; "
                                                   r"its rows \(4 bytes\) must hold whole elements: give it shape \(n, 4\)"):
        bind(engine, read_as("float4"), "flat")


@pytest.mark.parametrize("element, shape, dtype, fits", [
    ("float4", (8, 4), "float32", True),
    ("float", (8, 4), "float32", True),       # rows of 4 floats read one float at a time
    ("float", (8,), "float32", True),
    ("float3", (8, 3), "float32", False),     # float3 elements are 16 bytes apart
    ("float2", (8, 2), "float32", True),
    ("float", (8,), "uint32", False),         # integers read as floats
    ("uint", (8,), "float32", False),         # floats read as integers
    ("uint", (8, 4), "uint8", True),          # packed bytes
    ("uint", (8,), "uint8", False),           # one byte a row: the last reads past the end
    ("int4", (8, 4), "uint32", True),         # signedness is the shader's choice
    ("float", (8,), "float64", False),
    ("double", (8,), "float64", True),
])
def test_element_types(engine, element, shape, dtype, fits):
    engine.create_shared_buffer("b", shape, dtype)
    if fits:
        bind(engine, read_as(element), "b")
    else:
        with pytest.raises(cressim.BindingError, match=f"reads {element} elements.*bound to 'b'"):
            bind(engine, read_as(element), "b")


def test_struct_elements_need_whole_rows(engine):
    engine.create_shared_buffer("rows", (8, 4), "uint32")  # 16-byte rows, 16-byte P
    bind(engine, STRUCT, "rows")
    engine.create_shared_buffer("short", (8, 3), "uint32")
    with pytest.raises(cressim.BindingError, match=r"reads P elements \(16 bytes each\).*'short' \(8, 3\) uint32"):
        bind(engine, STRUCT, "short")


def test_internal_buffers_are_checked_too(engine):
    bind(engine, read_as("float4"), "transform.positions")
    with pytest.raises(cressim.BindingError, match=r"reads uint4 elements.*'transform.positions' \(2, 4\) float32"):
        bind(engine, read_as("uint4"), "transform.positions")
