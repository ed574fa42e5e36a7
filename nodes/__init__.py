"""Compositor node groups of vfxstereo, defined in code (Blender 5.0 compositor).

One builder function per group is the source of truth; each group matches a reference function of
:mod:`vfxstereo.composite` (the tests render every group headless and compare):

==============================  ==================================  ===========================================
builder                         group                               reference
==============================  ==================================  ===========================================
``build_premultiplied_over()``  vfxstereo Premultiplied Over        ``composite.over(fg, bg)``
``build_zkey_insert()``         vfxstereo Z-Key Insert              ``composite.insert_into_plate(plate, front,
                                                                    element, back)``
``build_layer_holdout(n)``      vfxstereo Layer Holdout (n layers)  ``composite.holdout(stack, disparity)``
``build_stack_split(n)``        vfxstereo Stack Split (n layers)    ``composite.split(stack, disparity)``
==============================  ==================================  ===========================================

``build_zkey_tree`` assembles them into the scene's compositing tree (the add-on's "Build z-key
compositor").

Alpha convention: every colour socket carries **premultiplied**, scene-linear RGBA (Blender's own
convention for float images and renders, and the stack EXR's); nothing is unpremultiplied inside a group.
Disparities follow vfxstereo: larger is nearer; an element at disparity D is in front of the layers with
``d <= D`` and behind those with ``d > D``.

The package imports ``bpy`` and never the add-on; it is bundled inside the extension and imported by the
tests from the repository.
"""

from .layer_holdout import build_layer_holdout
from .premultiplied_over import build_premultiplied_over
from .stack_split import build_stack_split
from .zkey_insert import build_zkey_insert
from .zkey_tree import build_zkey_tree

__all__ = ["build_layer_holdout", "build_premultiplied_over", "build_stack_split", "build_zkey_insert",
           "build_zkey_tree"]
