"""Z-Key Insert: an element composed into the plate between the front and the back of a layer stack.

Reference: :func:`vfxstereo.composite.insert_into_plate`. Per channel (R, G, B and A, all premultiplied)::

    comp = plate + (1 - A_F) * E - A_E * min((1 - A_F) * B, plate)

``front over element over back`` written around the plate: wherever the element is empty the comp *is* the
plate, bit for bit; elsewhere only the part of the back the element covers is replaced. With
``plate = front over back`` (a stack without its plate) it equals the comp of the stack alone.
"""

from __future__ import annotations

from ._build import group

NAME = "vfxstereo Z-Key Insert"

DESCRIPTION = ("Element composed into the plate between Front and Back (premultiplied RGBA; plate alpha 1): "
               "plate + (1 - A_F) E - A_E min((1 - A_F) B, plate), per channel. "
               "Reference: vfxstereo.composite.insert_into_plate")


def build_zkey_insert():
    """The Z-Key Insert group.

    ========  =====  ==========================================================================
    socket    type   meaning
    ========  =====  ==========================================================================
    Plate     Color  the reference view the stack was solved from, scene-linear, alpha 1
    Front     Color  premultiplied: the layers in front of the element, flattened (alpha A_F)
    Element   Color  premultiplied: the CG element or render (alpha A_E)
    Back      Color  premultiplied: the layers behind the element, flattened
    Comp      Color  output: premultiplied comp (alpha 1 where the plate is opaque)
    ========  =====  ==========================================================================

    Alpha convention: every socket premultiplied; the formula is applied to the alpha channel too.

    Returns
    -------
    bpy.types.CompositorNodeTree
    """

    def build(g):
        plate = g.input("Plate", "NodeSocketColor", "The plate (reference view), scene-linear, alpha 1",
                        default=(0, 0, 0, 1))
        front = g.input("Front", "NodeSocketColor", "Premultiplied layers in front of the element, flattened",
                        default=(0, 0, 0, 0))
        element = g.input("Element", "NodeSocketColor", "Premultiplied element (CG render)", default=(0, 0, 0, 0))
        back = g.input("Back", "NodeSocketColor", "Premultiplied layers behind the element, flattened",
                       default=(0, 0, 0, 0))
        P = g.separate(plate, column=0)
        A_F = g.separate(front, column=0)[3]
        E = g.separate(element, column=0)
        B = g.separate(back, column=0)
        see = g.math("SUBTRACT", 1.0, A_F, column=1)  # (1 - A_F): how much of the back the plate shows
        out = []
        for c in range(4):
            seen = g.math("MINIMUM", g.math("MULTIPLY", see, B[c], column=2), P[c], column=3)
            added = g.math("ADD", P[c], g.math("MULTIPLY", see, E[c], column=2), column=3)
            out.append(g.math("SUBTRACT", added, g.math("MULTIPLY", E[3], seen, column=4), column=5))
        g.output("Comp", "NodeSocketColor", "Premultiplied comp: the plate with the element between the layers",
                 g.combine(out, column=6))

    return group(NAME, DESCRIPTION, build)
