"""Shared fixtures: one GL context per test session (EGL; llvmpipe where there is no GPU)."""
from __future__ import annotations

import pytest

from synthcompose.gl import GLContext


@pytest.fixture(scope="session")
def gl():
    ctx = GLContext()
    yield ctx
    ctx.release()


@pytest.fixture
def gl_clean(gl):
    """The session context; fails the test if it leaves a GL error behind."""
    gl.activate()  # a batch run by an earlier test made its own context current
    gl.ctx.error  # reset
    yield gl
    gl.activate()
    assert gl.ctx.error == "GL_NO_ERROR"


def pytest_report_header(config):
    try:
        g = GLContext()
        name = g.renderer_name
        g.release()
    except Exception as exc:  # noqa: BLE001 - a header must not fail the run
        name = f"unavailable ({exc})"
    return f"OpenGL: {name}"
