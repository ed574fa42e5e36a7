"""Premultiplied Over: ``Foreground over Background`` for premultiplied RGBA (Porter-Duff).

Reference: :func:`vfxstereo.composite.over`. The Factor fades the foreground in, as Blender's Alpha Over
does: ``Factor * Foreground + (1 - Factor * A_fg) * Background``; with Factor 1 it is exactly
``Foreground + (1 - A_fg) * Background``, and with Factor 0 it is the Background.
"""

from __future__ import annotations

from ._build import group

NAME = "vfxstereo Premultiplied Over"

DESCRIPTION = ("Foreground over Background, both premultiplied RGBA (scene-linear), result premultiplied: "
               "F + (1 - F.a) * B. Factor fades the foreground in (0: Background only). "
               "Reference: vfxstereo.composite.over")


def build_premultiplied_over():
    """The Premultiplied Over group.

    ============  =====  ======================================================================
    socket        type   meaning
    ============  =====  ======================================================================
    Foreground    Color  premultiplied RGBA in front
    Background    Color  premultiplied RGBA behind
    Factor        Float  0..1, how much of the foreground is composited (1: a plain over)
    Image         Color  output: premultiplied ``Factor * F + (1 - Factor * F.a) * B``
    ============  =====  ======================================================================

    Alpha convention: premultiplied in and out, never unpremultiplied (Alpha Over with Straight Alpha off).

    Returns
    -------
    bpy.types.CompositorNodeTree
    """

    def build(g):
        fg = g.input("Foreground", "NodeSocketColor", "Premultiplied RGBA in front", default=(0, 0, 0, 0))
        bg = g.input("Background", "NodeSocketColor", "Premultiplied RGBA behind", default=(0, 0, 0, 0))
        factor = g.input("Factor", "NodeSocketFloat", "How much of the foreground is composited (1: over)",
                         default=1.0, min_value=0.0, max_value=1.0)
        over = g.node("CompositorNodeAlphaOver", 1, Foreground=fg, Background=bg, Factor=factor,
                      Straight_Alpha=False)
        g.output("Image", "NodeSocketColor", "Premultiplied Foreground over Background", over.outputs["Image"])

    return group(NAME, DESCRIPTION, build)
