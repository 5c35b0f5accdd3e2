"""Units, frames and descriptions of the streams each simulation records itself (``FlightLog(schema=...)``).

Streams recorded by components through a recorder (navigators, mission managers, the PFCM controller)
are registered next to their record calls with ``log.register_stream``. Layout: ``docs/log-format.md``.
Euler angles are 3-2-1 (yaw, pitch, roll applied in that order) and stored as (roll, pitch, yaw).
"""

from __future__ import annotations

NED = "NED world (origin at the scenario's home)"
EULER = ("rad", "3-2-1 Euler angles (roll, pitch, yaw) of body FRD relative to NED world", "attitude")
YACS = "YACS unit (+-500 = full stick)"

#: the R-MAX loop (app/loop.py): palace, hover, pfcm and witas-homing missions
RMAX_STREAMS = {
    "truth": {"position": ("m", NED, "true position of the body origin"),
              "velocity": ("m/s", NED, "true velocity"),
              "euler": (EULER[0], EULER[1], "true attitude"),
              "body_rates": ("rad/s", "body FRD", "true angular rates (p, q, r)")},
    "estimate": {"position": ("m", NED, "navigator's position estimate (meaningless where valid is false)"),
                 "velocity": ("m/s", NED, "navigator's velocity estimate"),
                 "euler": (EULER[0], EULER[1], "navigator's attitude estimate"),
                 "source": ("text", "", "navigation source in use: gps, mpe, inertial or vision"),
                 "valid": ("bool", "", "the estimate is a fix (false before the first one)")},
    "reference": {"position": ("m", NED, "position reference given to the controller"),
                  "velocity": ("m/s", NED, "velocity reference"),
                  "yaw": ("rad", "heading from north, clockwise", "heading reference")},
    "command": {k: (YACS, "", f"{n} command to the YACS") for k, n in (
        ("ail", "lateral cyclic (aileron)"), ("ele", "longitudinal cyclic (elevator)"), ("rud", "yaw (rudder)"),
        ("thr", "collective (throttle)"))},
    "status": {"mode": ("text", "", "mission mode"), "source": ("text", "", "navigation source"),
               "coherence": ("1", "", "tracker coherence, eq. 2.3 of seed 000 (0..1)"),
               "mpe_rate_hz": ("Hz", "", "rate of MPE fixes"), "laser_ok": ("bool", "", "laser has a return"),
               "tracking": ("bool", "", "the tracker holds a point"),
               "rejected_samples": ("1", "", "measurements the navigator rejected so far (Health)"),
               "rejected_ranges": ("1", "", "range readings the navigator rejected so far (Health)"),
               "integrity": ("1", "", "navigator integrity: 0 ok, 1 degraded, 2 unusable (-1 unknown)"),
               "hpl_m": ("m", "horizontal", "navigator's horizontal protection level (inf: none)"),
               "k2": ("1", "", "consistency factor k^2 inflating the covariance in the HPL")},
    "actuator": {"controller": (YACS, "(ail, ele, rud, thr)", "controller output before the sweep injection"),
                 "injection": (YACS, "(ail, ele, rud, thr)", "chirp added at the actuator (loop broken here)"),
                 "applied": (YACS, "(ail, ele, rud, thr)", "what the vehicle received")},
    "nav_init": {"source": ("text", "", "where the start came from: survey, truth+noise, operator, static, ..."),
                 "position": ("m", NED, "position the navigator was started at (NaN: not given)"),
                 "velocity": ("m/s", NED, "velocity the navigator was started at (NaN: not given)"),
                 "attitude": (EULER[0], EULER[1], "attitude the navigator was started at (NaN: not given)")},
    "touchdown": {"position": ("m", NED, "true position at ground contact"),
                  "speed": ("m/s", "", "true speed at ground contact")},
}

def _status(frame: str) -> dict:
    """The ``status`` stream of a system whose logger records the navigator's integrity (``sim/parts.IntegrityStatus``)."""
    return {"mode": ("text", "", "mission mode"), "source": ("text", "", "navigation source (Health.source)"),
            "integrity": RMAX_STREAMS["status"]["integrity"],
            "hpl_m": ("m", frame, "navigator's horizontal protection level (inf: none)"),
            "k2": RMAX_STREAMS["status"]["k2"]}


_DECK_STATE = {
    "position": ("m", "vehicle body FRD", "position of the deck origin relative to the vehicle (seed 003 eq. 2.2)"),
    "euler": ("rad", "3-2-1 Euler angles of the deck frame relative to the vehicle body frame",
              "relative attitude (eq. 2.8-2.12)"),
    "velocity": ("m/s", "vehicle body FRD", "rate of change of position as seen from the vehicle (eq. 2.5-2.6)"),
    "deck_rates": ("rad/s", "deck frame", "the deck's body rates (p_d, q_d, r_d)"),
}
_DECK_ORDER = "state order: position (m), euler (rad), velocity (m/s), deck_rates (rad/s)"

#: the deck landing (app/deck_parts.py)
DECK_STREAMS = {
    "truth": {k: (u, f, "true " + d) for k, (u, f, d) in _DECK_STATE.items()},
    "estimate": {**{k: (u, f, "UKF estimate of the " + d) for k, (u, f, d) in _DECK_STATE.items()},  # at the step
                 "sigma": ("mixed", _DECK_ORDER, "UKF 1-sigma of the 12 states"),
                 "nees": ("1", "", "normalised estimation error squared of the 12 states"),
                 "mode": ("text", "", "mission mode")},
    "vehicle": {"position": ("m", NED, "true vehicle position"), "velocity": ("m/s", NED, "true vehicle velocity"),
                "euler": (EULER[0], EULER[1], "true vehicle attitude"),
                "gear_height": ("m", "along the deck normal", "height of the landing gear above the deck plane")},
    "deck": {"position": ("m", NED, "true deck origin"),
             "euler": ("rad", "3-2-1 Euler angles of the deck frame relative to NED world", "true deck attitude")},
    "command": {"roll": ("rad", "", "commanded roll"), "pitch": ("rad", "", "commanded pitch"),
                "yaw_rate": ("rad/s", "", "commanded yaw rate"),
                "throttle": ("1", "", "normalised throttle command (eq. 4.32-4.33)")},
    "reference": {"position": ("m", "level-deck frame turned to north (NED axes), relative to the deck",
                               "desired position of the tau trajectory (NaN while hovering)"),
                  "velocity": ("m/s", "NED axes, relative to the deck", "desired velocity"),
                  "accel": ("m/s^2", "NED axes", "commanded acceleration")},
    "camera": {"blobs": ("1", "", "blobs the navigator found in the frame (t: the frame's stamp)"),
               "lights_used": ("1", "", "lights associated and used"),
               "rejected": ("1", "", "blobs the association gated out"),
               "nis": ("1", "", "normalised innovation squared of the update"),
               "dof": ("1", "", "degrees of freedom of the NIS"),
               "bearing_rms": ("rad", "camera", "RMS bearing residual of the update")},
    "nav_init": {"x0": ("mixed", _DECK_ORDER, "UKF initial state"),
                 "sigma": ("mixed", _DECK_ORDER, "UKF initial 1-sigma"),
                 "source": ("text", "", "how the filter was started or restarted: static (eq. 5.12), truth+noise "
                                        "(the Vicon start, NavInit from the simulation), restart from a yaw")},
    "imu_dropped": {"reason": ("text", "", "why the navigator dropped an IMU sample")},
    "camera_clock": {"step": ("s", "", "step of the camera's stamps against its frame counter x frame interval "
                                       "(t: the corrected stamp)"),
                     "offset": ("s", "", "the camera clock's offset subtracted from its stamps from now on"),
                     "stamp": ("s", "", "the frame's stamp as received")},
    "touchdown": {"rel_speed": ("m/s", "", "true speed of the gear relative to the deck point it meets"),
                  "pos_err": ("m", "deck plane", "true gear distance from the desired landing location"),
                  "on_deck": ("bool", "", "the gear is on the square plate"),
                  "gear_deck_m": ("m", "deck x, y", "true gear contact point on the plate (x forward, y right)"),
                  "att_mismatch": ("deg", "", "angle between the vehicle's and the deck's z axes")},
    "retarget_skipped": {"reason": ("text", "", "why the touchdown point was not re-aimed")},
    "status": _status("vehicle body FRD x, y (of the relative position: the UKF's P[0:2, 0:2])"),
}

#: the CONDOR orbit (app/condor_parts.py)
CONDOR_STREAMS = {
    "truth": {**{k: v for k, v in RMAX_STREAMS["truth"].items()},
              "airspeed": ("m/s", "", "true airspeed"), "beta": ("rad", "", "sideslip angle")},
    "vision": {"radius": ("m", "horizontal", "vision ground range to the tent (seed 004 eq. 3.9-3.24), NaN if invalid"),
               "true_radius": ("m", "horizontal", "true ground range to the tent"),
               "valid": ("bool", "", "a radius was computed"), "tracked": ("bool", "", "the tent is tracked"),
               "X": ("px", "image, centred, right", "tent column from the image centre"),
               "Y": ("px", "image, centred, up", "tent row from the image centre"),
               "tilt_error": ("rad", "", "camera AHRS tilt error"),
               "roll_error": ("rad", "", "camera AHRS roll error"),
               "cam_roll": ("rad", "", "true camera roll"), "cam_tilt": ("rad", "", "true camera tilt (down negative)"),
               "pan_pot": ("rad", "relative to the fuselage", "pan potentiometer reading"),
               "pan": ("rad", "relative to the fuselage", "true pan"),
               "bearing": ("rad", "camera pan axis", "bearing of the tent from the vision solution (Psi_VB)"),
               "reason": ("text", "", "why the radius is invalid")},
    "control": {"R": ("m", "horizontal", "radius the outer loop used (GPS in the loiter; vision, predicted across the link, in the orbit)"),
                "Rdot": ("m/s", "", "radius rate"),
                "base": ("rad/s", "", "base heading rate (eq. 5.2 / 7.1)"),
                "err": ("rad/s", "", "heading-rate correction from the radius error (eq. 5.1)"),
                "psidot_ref": ("rad/s", "", "heading-rate reference (eq. 5.3)"),
                "phi_ref": ("rad", "", "bank reference (eq. 5.4)"), "psidot": ("rad/s", "", "measured heading rate"),
                "bank_hold": ("bool", "", "bank hold engaged (eq. 5.7)"),
                "aileron": ("rad", "", "aileron deflection"), "elevator": ("rad", "", "elevator deflection"),
                "rudder": ("rad", "", "rudder deflection"), "throttle": ("1", "", "throttle 0..1"),
                "mode": ("text", "", "gps_loiter or vision_orbit")},
    "estimate": {"position": ("m", NED, "navigator's aircraft position: smoothed GPS in the loiter, tent - range along "
                              "compass + pan pot + vision bearing (eq. 3.23-3.24) after the switch; not flown on"),
                 "euler": (EULER[0], EULER[1], "AHRS attitude (navigator)"),
                 "valid": ("bool", "", "the position is a fix (GPS, or a vision fix after the switch)"),
                 "source": ("text", "", "gps (loiter) or vision (orbit)"),
                 "radius": ("m", "horizontal", "range to the tent the guidance flies on (GPS or vision filter)"),
                 "radius_valid": ("bool", "", "the range is fresh enough to fly on"),
                 "airspeed": ("m/s", "", "pitot airspeed (navigator)"),
                 "height": ("m", "above the ground", "eq. 2.1-corrected barometric height (navigator)")},
    "uplink": {"sent_at": ("s", "", "time the ground station sent the radius fix (t is the frame's instant)"),
               "delivered": ("bool", "", "the fix crossed the telemetry link (false: dropped)"),
               "radius": ("m", "horizontal", "the fix's vision range")},
    "nav_init": {"source": ("text", "", "where the initialisation came from (survey: the tent's position)"),
                 "position": ("m", NED, "the tent's surveyed position given to the navigator"),
                 "velocity": ("m/s", NED, "not given (NaN)"), "attitude": (EULER[0], EULER[1], "not given (NaN)")},
    "click": {"pixel": ("px", "image (u right, v down)", "the operator's click that starts the tracker on the tent")},
    "status": _status("horizontal NED (of the estimate's position)"),
}

#: the CONDOR ground test (sim/condor_ground.py): one row per table row, ``t`` is the row index
_ROW = ("1", "", "row index over Tables 4.1-4.2 (not a time)")
CONDOR_GROUND_STREAMS = {
    "truth": {"t": _ROW, "position": ("m", "NED, origin under the camera", "where the tent is"),
              "euler": ("rad", "", "zeros (a static test)")},
    "estimate": {"t": _ROW, "position": ("m", "NED, origin under the camera", "the configured method's tent position"),
                 "euler": ("rad", "", "zeros (a static test)")},
    "ground_test": {"t": _ROW, "table": ("text", "", "seed 004 table (4.1 or 4.2)"), "row": ("1", "", "row index"),
                    "true_radius": ("m", "horizontal", "true ground range"),
                    "published_error_pct": ("%", "", "the thesis' flight-hardware error of the row"),
                    **{f"{k}_radius": ("m", "horizontal", f"ground range, {d}") for k, d in (
                        ("thesis", "thesis method"), ("ours", "our method"), ("configured", "configured method"))},
                    **{f"{k}_error_pct": ("%", "", f"relative radius error, {d}") for k, d in (
                        ("thesis", "thesis method"), ("ours", "our method"), ("configured", "configured method"))}},
}

_NE = "north, east of the NED world"

#: the MAV target geo-location (app/geoloc_parts.py, seed 002 ch. 7)
GEOLOC_STREAMS = {
    "truth": {**{k: v for k, v in RMAX_STREAMS["truth"].items() if k != "body_rates"},
              "airspeed": ("m/s", "", "true airspeed")},
    "telemetry": {"position": ("m", NED, "GPS position in the telemetry (noise + bias)"),
                  "heading": ("rad", "from north, clockwise", "GPS-derived heading (course over ground) in the telemetry"),
                  "height": ("m", "above the take-off ground", "barometric height in the telemetry"),
                  "ground_speed": ("m/s", "", "GPS ground speed in the telemetry"),
                  "true_yaw": ("rad", "from north, clockwise", "true yaw of the airframe"),
                  "true_course": ("rad", "from north, clockwise", "true course over ground")},
    "control": {"mode": ("text", "", "mission mode"),
                "psidot_ref": ("rad/s", "", "heading-rate reference of the figure-eight guidance"),
                "phi_ref": ("rad", "", "bank reference"),
                "cross_track": ("m", "horizontal", "cross-track error from the figure-eight path")},
    "frame": {"visible": ("bool", "", "the target is inside the frame (40 px margin)"),
              "true_pixel": ("px", "image (u right, v down)", "true image position of the target"),
              "cam_roll_error": ("rad", "", "gimbal residual roll from nadir"),
              "cam_pitch_error": ("rad", "", "gimbal residual pitch from nadir"),
              "position": ("m", NED, "true aircraft position at the frame"),
              "yaw": ("rad", "from north, clockwise", "true yaw at the frame")},
    "click": {"pixel": ("px", "image (u right, v down)", "the operator's click on the target"),
              "true_pixel": ("px", "image (u right, v down)", "true image position of the target")},
    "target": {"position": ("m", _NE, "true target position")},
    "geoloc_result": {"sim_time": ("s", "", "simulated time the run reached (NaN when it stopped on an error)"),
                      "est_reg": ("m", _NE, "final RLS target estimate from registration"),
                      "est_reg_valid": ("bool", "", "the registration RLS has started"),
                      "est_map": ("m", _NE, "final RLS target estimate from the map-based samples"),
                      "est_map_valid": ("bool", "", "the map-based RLS has started"),
                      "target_sigma": ("m", "", "sqrt of the trace of the registration RLS covariance"),
                      "rejected": ("1", "", "registration samples the RLS gate rejected"),
                      "reinits": ("1", "", "restarts of the registration RLS"),
                      "frames_tracked": ("1", "", "frames in which the target tracker held the target")},
    "sample": {"reg": ("m", _NE, "target position from registration (NaN when it failed)"),
               "map": ("m", _NE, "target position from the map-based ray to flat ground"),
               "est_reg": ("m", _NE, "RLS estimate from the registration samples so far"),
               "est_map": ("m", _NE, "RLS estimate from the map-based samples so far"),
               "ok": ("bool", "", "the registration succeeded"),
               "reg_used": ("bool", "", "the RLS took the registration sample (quality and chi-square gate)"),
               "quality": ("1", "", "match quality of the registration (peak sharpness and ambiguity)"),
               "peak": ("1", "", "correlation peak"),
               "hough": ("bool", "", "Algorithm 1's Hough rotation was applied"),
               "heading_tel": ("rad", "from north, clockwise", "telemetry heading"),
               "heading_used": ("rad", "from north, clockwise", "heading used after the alignment"),
               "height_used": ("m", "above ground", "height used to scale the frame"),
               "gps": ("m", _NE, "telemetry GPS position"),
               "uv": ("px", "image (u right, v down)", "tracked target pixel")},
}
