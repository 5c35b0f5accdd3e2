"""visnav.vehicles: vehicle dynamics models (simulation side only)."""

from visnav.vehicles.rmax import (
    RMAX_TRANSFER_FUNCTIONS,
    ChannelModel,
    RmaxModel,
    RmaxParams,
    dc_gain,
    heave_height_gain,
    rmax_state_space,
)

__all__ = [
    "RMAX_TRANSFER_FUNCTIONS",
    "ChannelModel",
    "RmaxModel",
    "RmaxParams",
    "dc_gain",
    "heave_height_gain",
    "rmax_state_space",
]
