"""Layer Holdout: the matte of everything in front of a disparity, from the layers of a stack.

Reference: :func:`vfxstereo.composite.holdout`::

    matte = 1 - prod over layers with d_i > D of (1 - A_i)

one minus the transmittance (Eq. 7 of Szeliski & Golland) of the layers nearer than the element. A node
group has a fixed number of sockets, so there is one group per layer count (``build_layer_holdout(5)``
makes "vfxstereo Layer Holdout (5 layers)"). ``Disparity`` may be an image: the split is then made pixel by
pixel (e.g. a disparity made from a CG depth pass).
"""

from __future__ import annotations

from ._build import group

NAME = "vfxstereo Layer Holdout ({n} layers)"


def layer_sockets(g, n: int):
    """The element's disparity and ``n`` (layer, layer disparity) input pairs, as Group Input outputs.

    Layer ``i`` is the stack's ``i``-th layer (0 is furthest back); its disparity is a socket too, so a
    tree can feed the values of any stack (the z-key builder sets them as constants).
    """
    disparity = g.input("Disparity", "NodeSocketFloat",
                        "The element's disparity: layers with a larger disparity are in front of it",
                        default=0.0)
    layers = []
    for i in range(n):
        layer = g.input(f"Layer {i}", "NodeSocketColor", f"Premultiplied RGBA of layer {i} (0 is furthest back)",
                        default=(0, 0, 0, 0))
        d = g.input(f"Layer {i} Disparity", "NodeSocketFloat", f"Disparity of layer {i}", default=float(i))
        layers.append((layer, d))
    return disparity, layers


def build_layer_holdout(n: int):
    """The Layer Holdout group for stacks of ``n`` layers.

    ===================  =====  ===================================================================
    socket               type   meaning
    ===================  =====  ===================================================================
    Disparity            Float  the element's disparity (a value, or an image for one per pixel)
    Layer i              Color  premultiplied RGBA of layer i, i = 0 .. n-1, back to front
    Layer i Disparity    Float  that layer's disparity
    Matte                Float  output: alpha of the layers with disparity > Disparity, in [0, 1]
    ===================  =====  ===================================================================

    Alpha convention: reads only the layers' alpha (premultiplied or not, alpha is the same); the matte is
    an alpha, to multiply a premultiplied render by ``1 - Matte``.

    Parameters
    ----------
    n : int
        Number of layers, at least 1.

    Returns
    -------
    bpy.types.CompositorNodeTree
    """
    if n < 1:
        raise ValueError(f"a holdout needs at least one layer, got {n}")

    def build(g):
        disparity, layers = layer_sockets(g, n)
        transmit = 1.0
        for i, (layer, d) in enumerate(layers):
            alpha = g.separate(layer, column=2 * i)[3]
            in_front = g.math("GREATER_THAN", d, disparity, column=2 * i)  # 1 where d_i > D
            transmit = g.math("MULTIPLY", transmit,
                              g.math("SUBTRACT", 1.0, g.math("MULTIPLY", in_front, alpha, column=2 * i + 1),
                                     column=2 * i + 1), column=2 * i + 2)  # Eq. (7)
        g.output("Matte", "NodeSocketFloat", "Alpha of everything in front of the element",
                 g.math("SUBTRACT", 1.0, transmit, column=2 * n + 1))

    return group(NAME.format(n=n), f"Matte of the {n} layers in front of Disparity: 1 - prod(1 - A_i) over "
                 "d_i > Disparity (layer alpha; premultiplied or straight alike). "
                 "Reference: vfxstereo.composite.holdout", build)
