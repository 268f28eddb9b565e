"""The GL side of the models: vertex layout, textures, a model uploaded once
(:class:`GpuModel`), and the unit ground plane every object stands on (:class:`GroundPlane`)."""
from __future__ import annotations

from dataclasses import dataclass, replace

import moderngl
import numpy as np

from synthcompose.labels import HAS_INSTANCES, label_id
from synthcompose.models import Model

from .gl import GLContext
from .values import PART_SHIFT

#: the vertex buffer's attributes in order, with their float counts (models and the plane)
VERTEX_LAYOUT = (("in_position", 3), ("in_normal", 3), ("in_uv", 2), ("in_color", 4), ("in_material", 2))


def vertex_layout(prog: moderngl.Program, buffer: moderngl.Buffer, attributes) -> tuple:
    """A vertex_array content entry for ``buffer`` holding ``attributes`` ((name, floats), in
    order): the ones ``prog`` reads, the others skipped (a variant may not read them all)."""
    parts, names = [], []
    for name, floats in attributes:
        if prog.get(name, None) is not None:
            parts.append(f"{floats}f")
            names.append(name)
        else:
            parts.append(f"{4 * floats}x")
    return (buffer, " ".join(parts), *names)


@dataclass(frozen=True)
class GpuMaps:
    """What a lit draw of one part binds: sRGB base colour and linear tangent-space normal map;
    ``plate``: a number plate's image size, the part drawn with each object's plate (:mod:`.lit`);
    ``transmission``: above 0 for glass, drawn after the opaque parts over what they left
    (:meth:`.lit.LitDraw.draw`)."""

    base: moderngl.Texture | None
    normal: moderngl.Texture | None = None
    normal_scale: float = 1.0
    plate: tuple[int, int] | None = None
    transmission: float = 0.0


def mipmapped(gl: GLContext, image: np.ndarray) -> moderngl.Texture:
    """An RGBA8 texture of ``image`` (H, W, 4) uint8, repeating, trilinear."""
    tex = gl.texture((image.shape[1], image.shape[0]), 4, image, filter_linear=True)
    tex.build_mipmaps()
    tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    tex.repeat_x = tex.repeat_y = True
    return tex


class _Mesh:
    """Triangles on the GPU: a vertex buffer in :data:`VERTEX_LAYOUT`, a uint32 index buffer and
    optionally a buffer of tangents (``in_tangent``, 4 floats a vertex); a vertex array for each
    program that draws them."""

    def __init__(self, gl: GLContext, vertices: bytes, indices: bytes, tangents: bytes | None = None) -> None:
        self._gl = gl
        self._vbo = gl.own(gl.ctx.buffer(vertices))
        self.index_count = len(indices) // 4
        self._ibos = {False: gl.own(gl.ctx.buffer(indices))}
        self._tbo = gl.own(gl.ctx.buffer(tangents)) if tangents is not None else None
        self._vaos: dict[tuple[moderngl.Program, bool], moderngl.VertexArray] = {}

    def vao(self, prog: moderngl.Program, reverse: bool = False) -> moderngl.VertexArray:
        """The vertex array of this mesh for ``prog`` (made on first use); ``reverse``: its
        triangles in the opposite order (each one's vertices as they are), so that a draw of
        index range [first, first + count) in :meth:`reversed_range` is the same triangles
        drawn last to first."""
        if (prog, reverse) not in self._vaos:
            if reverse not in self._ibos:
                tris = np.frombuffer(self._ibos[False].read(), np.uint32).reshape(-1, 3)[::-1]
                self._ibos[reverse] = self._gl.own(self._gl.ctx.buffer(np.ascontiguousarray(tris).tobytes()))
            fmt = [vertex_layout(prog, self._vbo, VERTEX_LAYOUT)]
            if self._tbo is not None and prog.get("in_tangent", None) is not None:
                fmt.append(vertex_layout(prog, self._tbo, (("in_tangent", 4),)))
            self._vaos[prog, reverse] = self._gl.own(self._gl.ctx.vertex_array(
                prog, fmt, index_buffer=self._ibos[reverse], index_element_size=4))
        return self._vaos[prog, reverse]

    def reversed_range(self, first: int, count: int) -> int:
        """Where the index range [first, first + count) of this mesh starts in the reversed
        index buffer (:meth:`vao` with ``reverse``)."""
        return self.index_count - first - count

    def release(self) -> None:
        """Free the GL objects of this mesh (it is not drawn again)."""
        for obj in (*self._vaos.values(), self._vbo, *self._ibos.values(), self._tbo):
            if obj is not None:
                self._gl.free(obj)
        self._vaos.clear()


class GroundPlane(_Mesh):
    """The unit square [-1, 1]^2 at z = 0, facing +z, white and untextured: each object's local
    ground plane, placed by :meth:`~synthcompose.render.RenderObject.plane_matrix`."""

    def __init__(self, gl: GLContext) -> None:
        plane = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
        pdata = np.concatenate([plane, np.tile([0, 0, 1], (4, 1)), np.zeros((4, 2)), np.ones((4, 4)),
                                np.zeros((4, 2))], axis=1).astype(np.float32)
        super().__init__(gl, pdata.tobytes(), np.array([0, 1, 2, 0, 2, 3], np.uint32).tobytes())


class GpuModel(_Mesh):
    """One model on the GPU: all its parts in one vertex and one index buffer, a vertex array
    for each program that draws it.

    The passes that need no per-part state (shadow maps, ids, the sample fill) draw the whole
    model at once; the lit pass draws :attr:`ranges`, one per run of consecutive parts with
    the same maps (textures): parts without maps run together, in the file's order, so the
    pixels are those of a draw per part, with a handful of draws instead of one per part (4
    instead of 69 for the bundled car). Tangents (``in_tangent``, for normal maps) get a
    buffer of their own, zeros for parts without a map, only when some part has one.
    """

    def __init__(self, gl: GLContext, model: Model, programs: dict[str, moderngl.Program]) -> None:
        datas, indices, tangents, maps_of = [], [], [], []
        first = 0
        has_tangents = any(p.normal_texture is not None and p.tangents is not None for p in model.parts)
        for part in model.parts:
            datas.append(np.concatenate([part.positions, part.normals, part.uvs, part.colors, part.material],
                                        axis=1).astype(np.float32))
            indices.append(part.indices.astype(np.uint32).ravel() + np.uint32(first))
            first += len(part.positions)
            maps = GpuMaps(None if part.texture is None else mipmapped(gl, part.texture), plate=part.plate,
                           transmission=float(part.transmission))
            if part.normal_texture is not None and part.tangents is not None:
                maps = replace(maps, normal=mipmapped(gl, part.normal_texture), normal_scale=float(part.normal_scale))
            if has_tangents:
                tangents.append(np.zeros((len(part.positions), 4), np.float32) if maps.normal is None
                                else np.asarray(part.tangents, np.float32))
            maps_of.append(maps)
        super().__init__(gl, np.concatenate(datas).tobytes(), np.concatenate(indices).tobytes(),
                         np.concatenate(tangents).tobytes() if has_tangents else None)
        self._programs = programs
        #: (first index, index count, part label id or 0) of each id-pass draw: one per run of
        #: parts with the same label (one draw for a model without part labels)
        self.label_runs: list[tuple[int, int, int]] = []
        start = 0
        for idx, part in zip(indices, model.parts):
            lid = 0 if part.label is None else label_id(part.label)
            if lid and HAS_INSTANCES[lid]:
                raise ValueError(f"part label {part.label!r}: only classes without instances label parts")
            if self.label_runs and self.label_runs[-1][2] == lid:
                f, n, _ = self.label_runs[-1]
                self.label_runs[-1] = (f, n + len(idx), lid)
            else:
                self.label_runs.append((start, len(idx), lid))
            start += len(idx)
        #: (first index, index count, maps) of each lit draw
        self.ranges: list[tuple[int, int, GpuMaps]] = []
        start = 0
        for idx, maps in zip(indices, maps_of):
            plain = maps.base is None and maps.normal is None and maps.plate is None and not maps.transmission
            if self.ranges and plain and self.ranges[-1][2] == maps:
                f, n, _ = self.ranges[-1]
                self.ranges[-1] = (f, n + len(idx), maps)
            else:
                self.ranges.append((start, len(idx), maps))
            start += len(idx)
        #: (first index, index count) of the runs of opaque parts (no glass), run together
        self.opaque_runs: list[tuple[int, int]] = []
        for first, count, maps in self.ranges:
            if maps.transmission > 0.0:
                continue
            if self.opaque_runs and sum(self.opaque_runs[-1]) == first:
                self.opaque_runs[-1] = (self.opaque_runs[-1][0], self.opaque_runs[-1][1] + count)
            else:
                self.opaque_runs.append((first, count))

    def release(self) -> None:
        """Free the buffers, vertex arrays and textures of this model."""
        super().release()
        textures = {id(t): t for _, _, maps in self.ranges for t in (maps.base, maps.normal) if t is not None}
        for tex in textures.values():
            self._gl.free(tex)
        self.ranges = []

    def draw(self, name: str) -> None:
        """The whole model with the renderer's program ``name`` (its uniforms set)."""
        self.vao(self._programs[name]).render(moderngl.TRIANGLES)

    def draw_opaque(self, name: str) -> None:
        """The model's opaque parts (:attr:`opaque_runs`: not its glass) with program ``name``."""
        vao = self.vao(self._programs[name])
        if len(self.opaque_runs) == 1 and self.opaque_runs[0] == (0, self.index_count):
            vao.render(moderngl.TRIANGLES)
            return
        for first, count in self.opaque_runs:
            vao.render(moderngl.TRIANGLES, vertices=count, first=first)

    def draw_ids(self, index: int) -> None:
        """The id pass of object ``index`` (its other uniforms set): each part's value is the
        index, with its part label above :data:`PART_SHIFT` where it has one."""
        prog = self._programs["id"]
        if len(self.label_runs) == 1 and self.label_runs[0][2] == 0:
            prog["u_id"].value = index
            self.vao(prog).render(moderngl.TRIANGLES)
            return
        for first, count, lid in self.label_runs:
            prog["u_id"].value = index | (lid << PART_SHIFT)
            self.vao(prog).render(moderngl.TRIANGLES, vertices=count, first=first)
