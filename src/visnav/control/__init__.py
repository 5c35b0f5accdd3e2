"""visnav.control: controllers that turn a reference and a navigation estimate into commands."""

from visnav.control.rmax import (
    AxisMargins,
    DesignResult,
    RmaxPositionController,
    RmaxPositionGains,
    design_position_loop,
    loop_margins,
    normalized_plant,
    position_loop,
)

__all__ = [
    "AxisMargins",
    "DesignResult",
    "RmaxPositionController",
    "RmaxPositionGains",
    "design_position_loop",
    "loop_margins",
    "normalized_plant",
    "position_loop",
]
