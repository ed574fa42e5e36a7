"""Stack Split: the layers of a stack flattened in front of and behind a disparity.

Reference: :func:`vfxstereo.composite.split`. ``Front`` composites (Eq. 6) the layers with ``d_i > D``,
``Back`` those with ``d_i <= D`` (an element exactly on a plane goes over that plane's layer), so
``Front over Element over Back`` is the element between the layers. Each layer goes through a Premultiplied
Over whose Factor is 1 on its side of ``D`` and 0 on the other, which leaves the accumulated image as it
was: so ``D`` may be an image, and the split is then made pixel by pixel. One group per layer count.
"""

from __future__ import annotations

from ._build import group
from .layer_holdout import layer_sockets
from .premultiplied_over import build_premultiplied_over

NAME = "vfxstereo Stack Split ({n} layers)"


def build_stack_split(n: int):
    """The Stack Split group for stacks of ``n`` layers.

    ===================  =====  ===================================================================
    socket               type   meaning
    ===================  =====  ===================================================================
    Disparity            Float  the element's disparity (a value, or an image for one per pixel)
    Layer i              Color  premultiplied RGBA of layer i, i = 0 .. n-1, back to front
    Layer i Disparity    Float  that layer's disparity
    Front                Color  output: premultiplied flatten of the layers with d_i > Disparity
    Back                 Color  output: premultiplied flatten of the layers with d_i <= Disparity
    ===================  =====  ===================================================================

    Alpha convention: premultiplied in and out.

    Parameters
    ----------
    n : int
        Number of layers, at least 1.

    Returns
    -------
    bpy.types.CompositorNodeTree
    """
    if n < 1:
        raise ValueError(f"a split needs at least one layer, got {n}")
    over = build_premultiplied_over()

    def build(g):
        disparity, layers = layer_sockets(g, n)
        front = back = (0.0, 0.0, 0.0, 0.0)
        for i, (layer, d) in enumerate(layers):
            in_front = g.math("GREATER_THAN", d, disparity, column=2 * i)  # 1 where d_i > D
            behind = g.math("SUBTRACT", 1.0, in_front, column=2 * i)
            front = g.group_node(over, 2 * i + 1, Foreground=layer, Background=front,
                                 Factor=in_front).outputs["Image"]  # Eq. (6), layers in front
            back = g.group_node(over, 2 * i + 1, Foreground=layer, Background=back,
                                Factor=behind).outputs["Image"]  # Eq. (6), layers behind
        g.output("Front", "NodeSocketColor", "Premultiplied flatten of the layers in front of Disparity", front)
        g.output("Back", "NodeSocketColor", "Premultiplied flatten of the layers at or behind Disparity", back)

    return group(NAME.format(n=n), f"The {n} layers flattened in front of (d > Disparity) and behind "
                 "(d <= Disparity) the element, premultiplied RGBA. Reference: vfxstereo.composite.split",
                 build)
