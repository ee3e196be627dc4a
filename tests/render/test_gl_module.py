"""The GL module on a real offscreen context: programs, #line error mapping, enum defines,
exact uploads and read-backs, and the sprite tables as the shaders read them."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from riverflow.components.display import DisplayMode
from riverflow.components.status import FlowStatus
from riverflow.kernels.sprites import (MAX_PER_CELL, PARTICLES_PER_ROW, TEXELS_PER_PARTICLE,
                                       build_sprite_grid, empty_sprite_tables,
                                       fill_sprite_params)

pytestmark = pytest.mark.gl
PROBES = Path(__file__).parent / "shaders"


def test_enum_defines_name_every_member():
    from riverflow.engine import gl
    d = gl.enum_defines(FlowStatus, DisplayMode)
    assert d["FLOW_STATUS_INSIDE"] == FlowStatus.INSIDE
    assert d["FLOW_STATUS_ON_SKY"] == 7
    assert d["DISPLAY_MODE_PRE_ADVECTED"] == 6
    assert len(d) == len(FlowStatus) + len(DisplayMode)


def test_sources_frame_includes_with_line_directives():
    from riverflow.engine import gl
    sources = gl.shader_sources("water.glsl", {"X": 1})
    assert set(sources) == {"vertex", "fragment"}
    text, files = sources["fragment"]
    assert text.startswith("#version 330 core\n#define X 1\n#define FRAGMENT 1\n#line 1 0")
    assert files[0] == "water.glsl" and "common.glsl" in files and "params.glsl" in files
    # after an include, numbering resumes in the including file
    include_line = next(i for i, line in enumerate(gl._read_shader("water.glsl").splitlines(), 1)
                        if line.startswith('#include "common.glsl"'))
    assert f"#line {include_line + 1} 0" in text


def test_compile_error_names_file_and_line(gl_context):
    from riverflow.engine import gl
    with pytest.raises(gl.ShaderError) as info:
        gl.Program("broken.glsl", directory=PROBES)
    message = str(info.value)
    assert "broken.glsl" in message and "fragment" in message
    assert "broken.glsl:8" in message, message


def test_unknown_uniform_is_an_error(gl_context):
    from riverflow.engine import gl
    from riverflow.systems.draw import shader_defines
    program = gl.Program("sky.glsl", shader_defines())
    with pytest.raises(gl.ShaderError, match="no active uniform 'u_typo'"):
        program.set(u_typo=1.0)
    program.set_if_used(u_typo=1.0, u_fog_density=0.001)
    program.delete()


def test_check_errors_raises_on_a_gl_error(gl_context):
    from pyglet.gl import GL_TEXTURE_2D, GLException, glBindTexture

    from riverflow.engine import gl
    gl.check_errors("before")
    try:
        glBindTexture(GL_TEXTURE_2D + 12345, 0)
    except GLException as exc:  # pyglet's debug_gl (on in tests) reads the flag itself
        assert "invalid enum" in str(exc).lower()
    else:
        with pytest.raises(gl.GLError, match="GL_INVALID_ENUM"):
            gl.check_errors("after a bad enum")
    gl.check_errors("cleared")


@pytest.mark.parametrize("fmt_name", ["RGBA32F", "RGBA32I", "RGBA8", "R32F"])
def test_texture_round_trip_is_exact(gl_context, fmt_name, rng):
    from riverflow.engine import gl
    fmt = getattr(gl, fmt_name)
    shape = (5, 7, fmt.channels) if fmt.channels > 1 else (5, 7)
    if fmt.integer:
        data = rng.integers(-2**31, 2**31 - 1, shape).astype(np.int32)
    elif fmt.dtype == np.uint8:
        data = rng.integers(0, 256, shape).astype(np.uint8)
    else:
        data = rng.normal(0, 1e3, shape).astype(np.float32)
    tex = gl.Texture((7, 5), fmt)
    tex.upload(data)
    assert np.array_equal(gl.read_texture(tex), data)
    # a partial upload changes the first rows only
    tex.upload(np.zeros_like(data), rows=2)
    back = gl.read_texture(tex)
    assert not back[:2].any() and np.array_equal(back[2:], data[2:])
    tex.delete()
    gl.check_errors("texture round trip")


def test_framebuffer_read_back_is_top_row_first(gl_context):
    from riverflow.engine import gl
    colour = gl.Texture((6, 4), gl.RGBA8)
    fb = gl.Framebuffer([colour])
    image = np.zeros((4, 6, 4), np.uint8)
    image[0] = (10, 20, 30, 255)       # GL row 0 = bottom of the picture
    colour.upload(image)
    out = fb.read_rgba8()
    assert out.shape == (4, 6, 4)
    assert (out[-1] == (10, 20, 30, 255)).all() and not out[0].any()
    fb.delete()
    colour.delete()


def _probe(program, what: int, width: int, height: int):
    from riverflow.engine import gl
    target = gl.Texture((width, height), gl.RGBA32F)
    fb = gl.Framebuffer([target])
    fb.bind()
    gl.clear((0, 0, 0, 0), depth=False)
    program.use()
    program.set(u_what=what, u_params=2, u_grid=3, u_width=width) if what < 3 else \
        program.set(u_what=what, u_grid=3)
    empty = gl.Mesh(None, {})
    empty.draw(gl.TRIANGLES, count=3)
    out = gl.read_texture(target)
    for obj in (empty, fb, target):
        obj.delete()
    gl.check_errors("probe")
    return out


def _particles(rng, n, width, height, radius):
    alive = np.ones(n, bool)
    alive[::7] = False
    has_world = np.ones(n, bool)
    screen = (rng.random((n, 2)) * (width, height)).astype(np.float32)
    world = rng.normal(0, 500, (n, 3))
    offset = rng.normal(0, 5, (n, 2)).astype(np.float32)
    intensity = rng.random(n).astype(np.float32)
    status = rng.choice([FlowStatus.INSIDE, FlowStatus.LEAVING, FlowStatus.OUTSIDE], n)
    velocity = rng.normal(0, 1, (n, 2)).astype(np.float32)
    return alive, has_world, screen, world, offset, intensity, status.astype(np.uint8), velocity


def test_parameter_table_upload_reads_back_exactly_in_glsl(gl_context, rng):
    from riverflow.engine import gl
    from riverflow.systems.draw import shader_defines
    n = 700                                    # three texture rows of 256 slots
    cols = _particles(rng, n, 64, 48, 4.0)
    params, _, _ = empty_sprite_tables(1024, 4, 4)
    rows = fill_sprite_params(*cols, 4.0, n, params)
    assert rows == 3
    tex = gl.Texture((PARTICLES_PER_ROW * TEXELS_PER_PARTICLE, params.shape[0]), gl.RGBA32F)
    tex.upload(params, rows=rows)
    tex.bind(2)
    program = gl.Program("probe_tables.glsl", shader_defines(), directory=PROBES)
    width, height = 64, 11                     # 704 slots probed
    for texel in range(3):
        got = _probe(program, texel, width, height).reshape(-1, 4)[:n]
        want = params.reshape(-1, PARTICLES_PER_ROW, TEXELS_PER_PARTICLE, 4)[:, :, texel]
        assert np.array_equal(got, want.reshape(-1, 4)[:n]), f"texel {texel}"
    program.delete()
    tex.delete()


def test_indirection_grid_upload_reads_back_exactly_in_glsl(gl_context, rng):
    from riverflow.engine import gl
    from riverflow.systems.draw import shader_defines
    gw, gh, cell = 5, 4, 4.0
    n = 40                                     # some cells full, some with a terminator
    cols = _particles(rng, n, gw * cell, gh * cell, 2.0)
    alive, has_world, screen, _, _, intensity, status, _ = cols
    _, counts, grid = empty_sprite_tables(n, gw, gh)
    build_sprite_grid(alive, has_world, screen, intensity, status, n, 6.0, cell, gw, gh,
                      counts, grid)
    tex = gl.Texture((gw * MAX_PER_CELL // 4, gh), gl.RGBA32I)
    tex.upload(grid.reshape(gh, -1, 4))
    tex.bind(3)
    program = gl.Program("probe_tables.glsl", shader_defines(), directory=PROBES)
    got = _probe(program, 3, gw * MAX_PER_CELL, gh)[..., 0]
    assert np.array_equal(got.astype(np.int64), grid.astype(np.int64))
    assert (grid == -1).any() and (grid >= 0).any()
    program.delete()
    tex.delete()
