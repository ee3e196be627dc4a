"""The GL module on a real offscreen context: programs, #line error mapping, enum defines,
exact uploads and read-backs, the sprite tables as the shaders read them, and the sprite grid
that the GPU makes from them."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from riverflow.components.display import DisplayMode
from riverflow.components.status import FlowStatus
from riverflow.kernels.sprites import (PARTICLES_PER_ROW, SPRITE_RADIUS_FACTOR,
                                       TEXELS_PER_PARTICLE, SpriteSource, bin_texels,
                                       build_sprite_tables, empty_sprite_tables, sprite_bins,
                                       sprite_grid_shape)
from tests.kernels import sprites_reference as ref

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


@pytest.mark.parametrize("fmt_name", ["RGBA32F", "RGBA32I", "RGBA8", "R32F", "R32I"])
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
    # and from a row on: those rows of the array into the same rows
    tex.upload(data, first_row=1, rows=1)
    back = gl.read_texture(tex)
    assert not back[0].any() and np.array_equal(back[1:], data[1:])
    tex.upload(np.zeros_like(data), first_row=3, rows=1)
    back = gl.read_texture(tex)
    assert not back[3].any() and np.array_equal(back[[1, 2, 4]], data[[1, 2, 4]])
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
    program.set(u_what=what, u_params=2, u_bins=3, u_width=width)
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
    foam = rng.random(n).astype(np.float32)
    return SpriteSource(alive, has_world, screen, world, offset, intensity,
                        status.astype(np.uint8), velocity, foam,
                        np.zeros((n, 4), np.float32))


def _tables(src, radius, width, height):
    bins = sprite_bins(width, height, radius)
    params, starts, scratch = empty_sprite_tables(len(src.alive), bins)
    n_drawn, n_entries, rows = build_sprite_tables(src, radius, len(src.alive), bins, params,
                                                   starts, scratch, True)
    return bins, params, bin_texels(starts, bins), int(n_drawn), int(n_entries), int(rows)


def test_sprite_table_upload_reads_back_exactly_in_glsl(gl_context, rng):
    from riverflow.engine import gl
    from riverflow.systems.draw import shader_defines
    n = 700                                    # 600 entries: three texture rows of 256
    _, params, bins_texels, _, n_entries, rows = _tables(_particles(rng, n, 64, 48, 4.0), 4.0,
                                                         64, 48)
    assert rows == 3 and n_entries > 512
    tex = gl.BufferTexture(PARTICLES_PER_ROW * TEXELS_PER_PARTICLE * params.shape[0],
                           gl.RGBA32F)
    tex.write(params, rows * params[0].nbytes)         # the rows in use, as drawing does
    tex.bind(2)
    bins = gl.BufferTexture(bins_texels.size, gl.R32I)
    bins.write(np.ascontiguousarray(bins_texels))
    bins.bind(3)
    program = gl.Program("probe_tables.glsl", shader_defines(), directory=PROBES)
    width, height = 64, 11                     # 704 entries probed
    for texel in range(3):
        got = _probe(program, texel, width, height).reshape(-1, 4)[:n_entries]
        want = params.reshape(-1, PARTICLES_PER_ROW, TEXELS_PER_PARTICLE, 4)[:, :, texel]
        assert np.array_equal(got, want.reshape(-1, 4)[:n_entries]), f"texel {texel}"
    h, w = bins_texels.shape
    got = _probe(program, 3, w, h)[..., 0]
    assert np.array_equal(got.astype(np.int64), bins_texels.astype(np.int64))
    # the next frame's table goes into fresh storage (orphaned: no wait for the draws that
    # read this one), and what is drawn then reads it
    again = np.ascontiguousarray(params[:2] * 2.0)
    tex.write(again)
    got = _probe(program, 0, width, height).reshape(-1, 4)[:2 * PARTICLES_PER_ROW]
    want = again.reshape(-1, PARTICLES_PER_ROW, TEXELS_PER_PARTICLE, 4)[:, :, 0]
    assert np.array_equal(got, want.reshape(-1, 4))
    assert np.array_equal(tex.read()[:again.size // 4], again.reshape(-1, 4))
    for obj in (program, tex, bins):
        obj.delete()


def _gpu_grid(params, bins_texels, bins, radius, width, height):
    """The sprite grid as the draw system makes it (sprite_lists.glsl), read back."""
    from riverflow.engine import gl
    from riverflow.systems.draw import shader_defines
    cell, gw, gh = sprite_grid_shape(width, height, radius)
    table = gl.BufferTexture(PARTICLES_PER_ROW * TEXELS_PER_PARTICLE * params.shape[0],
                             gl.RGBA32F)
    table.write(params)
    table.bind(2)
    starts = gl.BufferTexture(bins_texels.size, gl.R32I)
    starts.write(np.ascontiguousarray(bins_texels))
    starts.bind(8)
    grid = gl.Texture((gw, gh), gl.RGBA32I, layers=4)
    fb = gl.Framebuffer([(grid, k) for k in range(4)])
    fb.bind()
    program = gl.Program("sprite_lists.glsl", shader_defines())
    program.use()
    program.set(u_params=2, u_bins=8, u_bin_px=(bins.bin_w, bins.bin_h),
                u_bin_margin=(bins.margin_x, bins.margin_y), u_bin_count=(bins.bw, bins.bh),
                u_sprite_radius_px=SPRITE_RADIUS_FACTOR * radius, u_cell_px=cell)
    empty = gl.Mesh(None, {})
    empty.draw(gl.TRIANGLES, count=3)
    out = gl.read_texture(grid)
    for obj in (empty, fb, grid, starts, table, program):
        obj.delete()
    gl.check_errors("sprite grid")
    return out, cell, gw, gh


def _entries_as_pool(params, n_drawn):
    """The drawn entries of a sprite table as the columns the grid's twin takes."""
    table = params.reshape(-1, TEXELS_PER_PARTICLE, 4)[:n_drawn]
    yes = np.ones(n_drawn, bool)
    return (yes, yes, table[:, 0, :2].copy(), table[:, 1, 2].copy(),
            table[:, 2, 0].astype(np.uint8))


@pytest.mark.parametrize("radius, width, height, n", [(2.0, 20, 16, 40), (4.0, 96, 64, 400),
                                                      (3.0, 61, 37, 300)])
def test_the_gpu_sprite_grid_lists_every_sprite_meeting_each_cell(gl_context, rng, radius, width,
                                                                  height, n):
    src = _particles(rng, n, width, height, radius)
    src.screen_px[:] = rng.uniform(-4 * radius, (width + 4 * radius, height + 4 * radius), (n, 2))
    bins, params, bins_texels, n_drawn, _, _ = _tables(src, radius, width, height)
    layers, cell, gw, gh = _gpu_grid(params, bins_texels, bins, radius, width, height)
    got = ref.grid_lists(layers)
    cols = _entries_as_pool(params, n_drawn)
    want, full = ref.build_sprite_grid(*cols, n_drawn, SPRITE_RADIUS_FACTOR * radius, float(cell),
                                       gw, gh)
    assert n_drawn > 20 and any(len(c) > 1 for c in want)
    for c, (g, w) in enumerate(zip(got, want)):
        assert len(g) == len(set(g)), c
        if len(w) < 16:                                  # not full: exactly the same sprites
            assert sorted(g) == sorted(w), c
        else:                                            # full: the 16 brightest
            levels = cols[3]
            assert len(g) == 16 and sorted(levels[g]) == sorted(levels[w]), c
    assert full == sum(len(g) == 16 for g in got)


def test_a_full_cell_keeps_the_brightest_sprites(gl_context, rng):
    n, width, height, radius = 60, 24, 24, 2.0
    src = _particles(rng, n, width, height, radius)
    src.alive[:] = True
    src.status[:] = FlowStatus.INSIDE
    src.screen_px[:] = rng.uniform(10.0, 14.0, (n, 2))    # all over the middle cells
    src.intensity[:] = rng.permutation(np.linspace(0.02, 1.0, n)).astype(np.float32)
    bins, params, bins_texels, n_drawn, _, _ = _tables(src, radius, width, height)
    layers, cell, gw, gh = _gpu_grid(params, bins_texels, bins, radius, width, height)
    got = ref.grid_lists(layers)
    levels = params.reshape(-1, TEXELS_PER_PARTICLE, 4)[:n_drawn, 1, 2]
    centres = params.reshape(-1, TEXELS_PER_PARTICLE, 4)[:n_drawn, 0, :2].astype(np.float64)
    full = 0
    for c, g in enumerate(got):
        cy, cx = divmod(c, gw)
        lo = np.array([cx, cy], float) * cell
        d = np.maximum(np.maximum(lo - centres, centres - lo - cell), 0.0)
        meeting = np.flatnonzero((d ** 2).sum(axis=1) <= (SPRITE_RADIUS_FACTOR * radius) ** 2)
        brightest = meeting[np.argsort(-levels[meeting], kind="stable")][:16]
        assert sorted(g) == sorted(brightest.tolist()), c
        full += len(meeting) > 16
    assert n_drawn == n and full >= 4


def test_the_gpu_timer_times_the_work_between_begin_and_end(gl_context):
    """GpuTimer (bench_gpu.py's GPU frame time): a span with many full-screen fills takes the
    GPU longer than an empty one, and both read back as finite non-negative milliseconds."""
    from riverflow.engine import gl
    from riverflow.engine.gl import gl as raw

    colour = gl.Texture((512, 512), gl.RGBA8)
    fb = gl.Framebuffer([colour])
    fb.bind()
    timer = gl.GpuTimer()
    try:
        timer.begin()
        timer.end()
        empty = timer.result_ms()
        timer.begin()
        for k in range(200):
            gl.clear((k / 200.0, 0.5, 0.25, 1.0), depth=False)
        fb.read_rgba8()                              # the clears are done within the span
        timer.end()
        busy = timer.result_ms()
        assert np.isfinite([empty, busy]).all() and 0.0 <= empty < busy
        assert raw.glIsQuery(timer.query)
    finally:
        query = timer.query
        timer.delete()
        assert timer.query == 0 and not raw.glIsQuery(query)
        fb.delete()
        colour.delete()
