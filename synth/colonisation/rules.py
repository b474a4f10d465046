"""Space colonisation's pure rules: the angle snap, ideal directions and the inter-connection force
(001 §4.1.2, §4.2.1), and segment hits."""
from __future__ import annotations

import numpy as np

# --------------------------------------------------------------------------- pure rules


def constrain_turn(turn_deg: np.ndarray | float, *, lo: float, hi: float, tolerance: float,
                   straight: bool = True) -> np.ndarray:
    """Snap turns from the parent segment into the allowed range (001 §4.1.2, fig. 73).

    Allowed are ``lo <= |turn| <= hi`` on either side and, when ``straight``,
    ``|turn| <= tolerance`` around straight ahead. A turn outside moves to
    the nearest allowed value on its own side.

    Parameters
    ----------
    turn_deg : float or ndarray
        Signed turns in degrees, in (-180, 180] (positive: left).
    lo, hi : float
        The range of allowed turns, degrees, 0 <= lo <= hi <= 180.
    tolerance : float
        Half-width of the straight-ahead range, degrees.
    straight : bool
        Whether the straight-ahead range is allowed.

    Returns
    -------
    ndarray
        Snapped signed turns, degrees.

    Examples
    --------
    >>> constrain_turn([20.0, -5.0, 10.0, 60.0], lo=30, hi=45, tolerance=7.5).tolist()
    [30.0, -5.0, 7.5, 45.0]
    """
    turn = np.asarray(turn_deg, dtype=float)
    mag = np.abs(turn)
    lo_edge, hi_edge = np.full_like(mag, lo), np.full_like(mag, hi)
    options = [np.clip(mag, lo_edge, hi_edge)]
    if straight:
        options.append(np.minimum(mag, tolerance))
    options_arr = np.stack(options)
    best = options_arr[np.argmin(np.abs(options_arr - mag), axis=0), np.arange(mag.size).reshape(mag.shape)] \
        if mag.ndim else options_arr[int(np.argmin(np.abs(options_arr - mag)))]
    return np.where(turn < 0, -best, best)


def _snap_turn(turn: float, lo: float, hi: float, tolerance: float, straight: bool) -> float:
    """:func:`constrain_turn` for one turn (the growth loop's hot path)."""
    mag = abs(turn)
    best = min(max(mag, lo), hi)
    if straight and abs(min(mag, tolerance) - mag) < abs(best - mag):
        best = min(mag, tolerance)
    return -best if turn < 0 else best


def ideal_directions(incident: np.ndarray, incoming: np.ndarray | None) -> np.ndarray:
    """A node's ideal directions for a new connection, as angles in degrees (001 §4.2.1).

    Parameters
    ----------
    incident : ndarray, shape (k, 2)
        Unit vectors from the node to each of its neighbours.
    incoming : ndarray, shape (2,), optional
        Unit vector of the connection that reached the node (parent → node);
        used when the node has no descendants (k <= 1).

    Returns
    -------
    ndarray
        Angles in degrees, counter-clockwise from east. With no descendants:
        straight on along the incoming connection and both perpendiculars
        ("perpendicular or parallel to the previous connection"; the fourth,
        back along it, is the connection itself). Otherwise the bisectors of
        consecutive connection directions around the node. Empty when the
        node has no connection at all.
    """
    incident = np.asarray(incident, dtype=float).reshape(-1, 2)
    if len(incident) <= 1:
        if incoming is None:
            if not len(incident):
                return np.zeros(0)
            incoming = -incident[0]
        base = np.degrees(np.arctan2(incoming[1], incoming[0]))
        return np.mod(base + np.array([0.0, 90.0, -90.0]), 360.0)
    ang = np.sort(np.mod(np.degrees(np.arctan2(incident[:, 1], incident[:, 0])), 360.0))
    gaps = np.diff(np.append(ang, ang[0] + 360.0))
    return np.mod(ang + gaps / 2, 360.0)


def connection_force(alpha_deg: np.ndarray | float, distance: np.ndarray | float,
                     threshold: float) -> np.ndarray:
    """001 eq. 3: force = ((180° − α)/180°) · ((threshold − |NC|)/threshold).

    Parameters
    ----------
    alpha_deg : float or ndarray
        Angle between the candidate connection and the nearest ideal direction, degrees in [0, 180].
    distance : float or ndarray
        Length of the candidate connection |NC|, same unit as ``threshold``.
    threshold : float
        The inter-connection distance threshold.

    Returns
    -------
    ndarray
        Force in [0, 1] (0 at or beyond the threshold).

    Examples
    --------
    >>> float(connection_force(90.0, 50.0, 100.0))
    0.25
    """
    alpha = np.asarray(alpha_deg, dtype=float)
    dist = np.asarray(distance, dtype=float)
    return (180.0 - alpha) / 180.0 * np.clip((threshold - dist) / threshold, 0.0, 1.0)


def _first_hit(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[int, float] | None:
    """The segment a→b that p→q meets first (touching included), and where along it; None if none.

    Parameters
    ----------
    p, q : ndarray, shape (2,)
        The proposed segment.
    a, b : ndarray, shape (k, 2)
        Candidate segments.

    Returns
    -------
    (index into a/b, parameter along a→b in [0, 1]) or None
    """
    r = q - p
    s = b - a
    denom = r[0] * s[:, 1] - r[1] * s[:, 0]
    ap = a - p
    safe = np.where(np.abs(denom) > 1e-12, denom, np.inf)  # parallel: t = u = 0, rejected below
    t = (ap[:, 0] * s[:, 1] - ap[:, 1] * s[:, 0]) / safe  # along p→q
    u = (ap[:, 0] * r[1] - ap[:, 1] * r[0]) / safe  # along a→b
    eps = 1e-9
    ok = np.isfinite(safe) & (t > eps) & (t <= 1 + eps) & (u >= -eps) & (u <= 1 + eps)
    if not ok.any():
        return None
    k = int(np.flatnonzero(ok)[np.argmin(t[ok])])
    return k, float(np.clip(u[k], 0.0, 1.0))


def _angle_between(a_deg: np.ndarray, b_deg: np.ndarray) -> np.ndarray:
    """Smallest absolute difference of angles, degrees in [0, 180]."""
    d = np.mod(np.asarray(a_deg) - np.asarray(b_deg), 360.0)
    return np.minimum(d, 360.0 - d)
