"""ClockSync against a simulated peer whose clock is offset, skewed and reached over jittery links."""

import numpy as np
import pytest

from visnav.estimation.clock_sync import ClockSync


class Peer:
    """Peer clock = (1 + skew) * ours + offset; one-way delays base + exponential jitter, rare spikes."""

    def __init__(self, rng, offset_ns=3_217_000_000_123.0, skew=80e-6, base_ns=300_000, jitter_ns=400_000,
                 spike_p=0.05, spike_ns=30_000_000):
        self.rng, self.offset, self.skew = rng, offset_ns, skew
        self.base, self.jitter, self.spike_p, self.spike = base_ns, jitter_ns, spike_p, spike_ns

    def clock(self, ours_ns):
        return (1.0 + self.skew) * ours_ns + self.offset

    def true_offset(self, ours_ns):
        return self.clock(ours_ns) - ours_ns

    def leg(self):
        d = self.base + self.rng.exponential(self.jitter)
        return d + (self.spike * self.rng.random() if self.rng.random() < self.spike_p else 0.0)

    def exchange(self, sync, t_send):
        """One request at our t_send; returns our receive time of the reply."""
        tc1, ts1 = sync.request(t_send)
        t_peer_rx = t_send + self.leg()
        tc1, ts1 = sync.answer(tc1, ts1, int(self.clock(t_peer_rx)))
        t_back = t_peer_rx + self.leg()
        sync.on_reply(tc1, ts1, int(t_back))
        return t_back


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_offset_converges_within_1ms_and_stamps_within_2ms(seed):
    rng = np.random.default_rng(seed)
    peer, sync = Peer(rng), ClockSync()
    t = 5_000_000_000_000  # our monotonic clock after ~83 min of uptime
    errs, stamp_errs = [], []
    for k in range(300):  # 30 s at 10 Hz
        t = int(t + 100_000_000)
        peer.exchange(sync, t)
        if k >= 20:  # after 2 s
            errs.append(sync.offset_at(t) - peer.true_offset(t))
            # a message the peer stamps with its clock at the instant it describes (our t_true)
            t_true = t + rng.uniform(-50e6, 0)
            stamp_errs.append(sync.to_ours(peer.clock(t_true)) - t_true)
            # and our estimate instant written in the peer's clock
            stamp_errs.append(sync.to_peer(t_true) - peer.clock(t_true))
    assert sync.synced
    assert np.max(np.abs(errs)) < 1e6, np.max(np.abs(errs)) / 1e6
    assert np.max(np.abs(stamp_errs)) < 2e6
    assert abs(sync.skew - peer.skew) < 20e-6  # drift rate learned
    assert sync.stats.rejected_rtt > 0  # the spikes were filtered
    assert 0.5 < sync.rtt_ms() < 3.0


def test_without_min_rtt_filter_spikes_would_bias():
    """The spikes are large enough to matter: one spiked sample alone is off by > 1 ms."""
    rng = np.random.default_rng(3)
    peer = Peer(rng, spike_p=1.0)
    s = ClockSync(rtt_slack_ns=10**12, outlier_floor_ns=10**12)  # filter off
    for k in range(50):
        peer.exchange(s, 10**12 + k * 100_000_000)
    assert abs(s.offset_at(10**12 + 49 * 10**8) - peer.true_offset(10**12 + 49 * 10**8)) > 1e6


def test_peer_reboot_resets_and_reconverges():
    rng = np.random.default_rng(4)
    peer, sync = Peer(rng, spike_p=0.0), ClockSync()
    t = 10**12
    for _ in range(50):
        t += 100_000_000
        peer.exchange(sync, t)
    peer.offset -= 2_000_000_000_000  # the autopilot rebooted: its boot clock restarts
    for _ in range(60):
        t += 100_000_000
        peer.exchange(sync, t)
    assert sync.stats.resets == 1
    assert abs(sync.offset_at(t) - peer.true_offset(t)) < 1e6


def test_answer_and_malformed_replies():
    s = ClockSync()
    assert s.answer(0, 123, 999) == (999, 123)
    assert s.answer(5, 123, 999) is None  # a reply, not a request
    assert not s.on_reply(1000, 2000, 1000)  # negative round trip
    assert not s.on_reply(0, 0, 10)  # tc1 = 0 is not a reply
    with pytest.raises(RuntimeError):
        s.offset_at(0)
    assert np.isnan(s.offset_ms())
