"""The one exception type for errors a user can cause.

Missing or corrupt files, views of different sizes, a disparity range that cannot work, NaN in a plate,
a stack that breaks the LayerStack rules: all raise :class:`VfxStereoError`. The command line turns it into
one line on stderr and exit status 2; library callers catch it like any other exception.
"""


class VfxStereoError(Exception):
    """An error caused by the input, stated in one line a user can act on."""

    def __str__(self) -> str:  # one line, whatever the message held
        return " ".join(super().__str__().split())
