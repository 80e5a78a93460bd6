//! The UDP link from the Vicon host to the control computers.
//!
//! Every packet carries the Vicon frame number as its sequence number. A packet is lost with the
//! probability of the loss model, otherwise it arrives after `latency + U(0, jitter)`, so jitter
//! can reorder packets; the receiver discards any packet older than the newest it has delivered
//! (UDP has no retransmission). Loss models:
//!
//! * Bernoulli: each packet lost independently with probability p.
//! * Gilbert–Elliott: a two-state Markov chain, Good → Bad with p_gb and Bad → Good with p_bg per
//!   packet, losing packets with probability `loss_good` / `loss_bad` in each state. Mean loss
//!   = (p_bg·loss_good + p_gb·loss_bad)/(p_gb + p_bg); mean burst length in Bad = 1/p_bg.
//!
//! The receiver monitors the link from the sequence numbers alone, as in the arena: packets
//! received, frames missing (lost on the link or never sent because the vehicle was not seen), the
//! longest run of missing frames and the longest time between two deliveries.

use crate::clock::Nanos;
use crate::rng::Stream;
use std::collections::VecDeque;

/// How packets are lost (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LossModel {
    /// Each packet lost independently.
    Bernoulli {
        /// Loss probability.
        p: f64,
    },
    /// Bursts: a two-state Markov chain.
    GilbertElliott {
        /// Good → Bad per packet.
        p_good_to_bad: f64,
        /// Bad → Good per packet (1/mean burst length).
        p_bad_to_good: f64,
        /// Loss probability in Good.
        loss_good: f64,
        /// Loss probability in Bad.
        loss_bad: f64,
    },
}

impl LossModel {
    /// Nothing is lost.
    pub const NONE: LossModel = LossModel::Bernoulli { p: 0.0 };
    /// Long-run fraction of packets lost.
    pub fn mean_loss(&self) -> f64 {
        match *self {
            LossModel::Bernoulli { p } => p,
            LossModel::GilbertElliott { p_good_to_bad: gb, p_bad_to_good: bg, loss_good, loss_bad } => {
                if gb + bg == 0.0 { loss_good } else { (bg * loss_good + gb * loss_bad) / (gb + bg) }
            }
        }
    }
}

/// A link's timing and loss.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LinkParams {
    /// Fixed delay of every packet.
    pub latency: Nanos,
    /// Extra delay, uniform in [0, jitter] per packet (it can reorder them).
    pub jitter: Nanos,
    /// The loss model.
    pub loss: LossModel,
}

/// What the receiver knows about the link (from sequence numbers and arrival times).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LinkStats {
    /// Packets sent.
    pub sent: u64,
    /// Packets the loss model dropped.
    pub lost_on_link: u64,
    /// Packets delivered to the receiver.
    pub received: u64,
    /// Arrived after a newer packet and were discarded.
    pub stale: u64,
    /// Frames never delivered, seen as gaps in the sequence numbers.
    pub missing_frames: u64,
    /// The longest run of consecutive missing frame numbers.
    pub longest_missing_run: u64,
    /// The longest time between two deliveries (ns).
    pub longest_gap_ns: i64,
}

/// One link carrying packets of `T` stamped with sequence numbers.
#[derive(Clone, Debug)]
pub struct Link<T> {
    params: LinkParams,
    loss_rng: Stream,
    jitter_rng: Stream,
    bad_state: bool,
    in_flight: VecDeque<(Nanos, u32, T)>,
    last_seq: Option<u32>,
    last_arrival: Option<Nanos>,
    stats: LinkStats,
    /// Total outages [from, to) (to = None: until the end); packets sent then are lost.
    outages: Vec<(Nanos, Option<Nanos>)>,
}

impl<T: Copy> Link<T> {
    /// A link drawing its losses and jitter from their own streams.
    pub fn new(params: LinkParams, loss_rng: Stream, jitter_rng: Stream) -> Self {
        Link {
            params,
            loss_rng,
            jitter_rng,
            bad_state: false,
            in_flight: VecDeque::with_capacity(64),
            last_seq: None,
            last_arrival: None,
            stats: LinkStats::default(),
            outages: Vec::new(),
        }
    }

    /// Adds total outages: every packet sent in [from, to) is lost (`to = None`: never ends).
    pub fn with_outages(mut self, outages: Vec<(Nanos, Option<Nanos>)>) -> Self {
        self.outages = outages;
        self
    }

    /// The link's fixed delay.
    pub fn latency(&self) -> Nanos {
        self.params.latency
    }

    /// The receiver's counts so far.
    pub fn stats(&self) -> &LinkStats {
        &self.stats
    }

    fn lost(&mut self) -> bool {
        match self.params.loss {
            LossModel::Bernoulli { p } => p > 0.0 && self.loss_rng.bernoulli(p),
            LossModel::GilbertElliott { p_good_to_bad, p_bad_to_good, loss_good, loss_bad } => {
                let switch = if self.bad_state { p_bad_to_good } else { p_good_to_bad };
                if self.loss_rng.bernoulli(switch) {
                    self.bad_state = !self.bad_state;
                }
                let p = if self.bad_state { loss_bad } else { loss_good };
                self.loss_rng.bernoulli(p)
            }
        }
    }

    /// Hands a packet to the network at time `now`.
    pub fn send(&mut self, now: Nanos, seq: u32, payload: T) {
        self.stats.sent += 1;
        let out = self.outages.iter().any(|(from, to)| now >= *from && to.is_none_or(|t| now < t));
        // the loss model draws even during an outage, so an outage does not shift later draws
        if self.lost() || out {
            self.stats.lost_on_link += 1;
            return;
        }
        let jitter = if self.params.jitter.0 > 0 {
            Nanos((self.jitter_rng.uniform() * self.params.jitter.0 as f64) as i64)
        } else {
            Nanos::ZERO
        };
        let arrival = now + self.params.latency + jitter;
        // keep the queue sorted by arrival time (ties keep send order)
        let idx = self.in_flight.partition_point(|(a, _, _)| *a <= arrival);
        self.in_flight.insert(idx, (arrival, seq, payload));
    }

    /// Delivers the next packet that has arrived by `now`, in arrival order, skipping stale ones.
    pub fn receive(&mut self, now: Nanos) -> Option<T> {
        // peek at the arrival time only: the payload is copied out once, when it is delivered
        while self.in_flight.front().is_some_and(|(arrival, _, _)| *arrival <= now) {
            let Some((_, seq, payload)) = self.in_flight.pop_front() else { break };
            if let Some(last) = self.last_seq {
                if seq <= last {
                    self.stats.stale += 1;
                    continue;
                }
                let missing = (seq - last - 1) as u64;
                self.stats.missing_frames += missing;
                self.stats.longest_missing_run = self.stats.longest_missing_run.max(missing);
            }
            if let Some(prev) = self.last_arrival {
                self.stats.longest_gap_ns = self.stats.longest_gap_ns.max((now - prev).0);
            }
            self.last_seq = Some(seq);
            self.last_arrival = Some(now);
            self.stats.received += 1;
            return Some(payload);
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Component;

    fn link(loss: LossModel, jitter_ms: i64) -> Link<u32> {
        let p = LinkParams { latency: Nanos::from_millis(20), jitter: Nanos::from_millis(jitter_ms), loss };
        Link::new(p, Stream::new(3, Component::LinkLoss, 0), Stream::new(3, Component::LinkJitter, 0))
    }

    #[test]
    fn lossless_link_delays_by_latency() {
        let mut l = link(LossModel::NONE, 0);
        l.send(Nanos(0), 0, 7);
        assert_eq!(l.receive(Nanos::from_millis(19)), None);
        assert_eq!(l.receive(Nanos::from_millis(20)), Some(7));
        // the receiver's counts: one sent and delivered, nothing lost, stale or missing
        let st = *l.stats();
        assert_eq!((st.sent, st.received, st.lost_on_link, st.stale, st.missing_frames), (1, 1, 0, 0, 0), "{st:?}");
    }

    /// The receiver's counts by hand: frames 0, 1 and 5 sent at 0, 5 and 30 ms arrive 20 ms
    /// later, at 20, 25 and 50 ms, so the gaps between deliveries are 5 and 25 ms (the longest
    /// 25 ms), and 2, 3 and 4 are missing (one run of 3). The longest gap is pinned from both sides: `now + prev`
    /// for `now − prev` fails it.
    #[test]
    fn the_longest_gap_and_missing_run_by_hand() {
        let mut l = link(LossModel::NONE, 0);
        for (seq, sent_ms) in [(0u32, 0i64), (1, 5), (5, 30)] {
            l.send(Nanos::from_millis(sent_ms), seq, seq);
            assert_eq!(l.receive(Nanos::from_millis(sent_ms + 20)), Some(seq));
        }
        let st = *l.stats();
        assert_eq!(
            (st.longest_gap_ns, st.missing_frames, st.longest_missing_run, st.received),
            (25_000_000, 3, 3, 3),
            "{st:?}"
        );
    }

    /// An outage on top of random loss: every packet sent in [10 s, 12 s) is lost, and outside
    /// it the link loses exactly the packets the same link without the outage loses (the loss
    /// model keeps drawing through the outage, so the outage does not shift later draws); the
    /// gap shows as a run of at least the 400 frames of 5 ms inside it and a silence of ≥ 2 s.
    #[test]
    fn an_outage_over_random_loss_loses_all_inside_and_the_same_outside() {
        let bern = LossModel::Bernoulli { p: 0.2 };
        let (from, to) = (Nanos::from_millis(10_000), Nanos::from_millis(12_000));
        let mut with = link(bern, 0).with_outages(vec![(from, Some(to))]);
        let mut without = link(bern, 0);
        let n = 8000u32;
        let (mut got_with, mut got_without) = (Vec::new(), Vec::new());
        for s in 0..n {
            let t = Nanos::from_millis(5 * s as i64);
            with.send(t, s, s);
            without.send(t, s, s);
            let later = t + Nanos::from_millis(20);
            while let Some(x) = with.receive(later) {
                got_with.push(x);
            }
            while let Some(x) = without.receive(later) {
                got_without.push(x);
            }
        }
        let inside = |s: &u32| (2000..2400).contains(s);
        assert!(got_with.iter().all(|s| !inside(s)), "a packet got through the outage");
        let outside: Vec<u32> = got_without.iter().copied().filter(|s| !inside(s)).collect();
        assert_eq!(got_with, outside);
        let lost_inside_anyway = got_without.iter().filter(|s| inside(s)).count() as u64;
        let st = *with.stats();
        assert_eq!(st.lost_on_link, without.stats().lost_on_link + lost_inside_anyway);
        assert!(st.longest_missing_run >= 400 && st.longest_gap_ns >= 2_000_000_000, "{st:?}");
        // 20 % outside (7600 packets: 1520 ± 3σ = 105) plus the 400 inside
        assert!((st.lost_on_link as f64 - (1520.0 + 400.0)).abs() < 105.0, "{}", st.lost_on_link);
    }

    /// The Gilbert–Elliott chain's stationary loss by hand: the bad state's share is
    /// gb/(gb + bg), so gb = bg = 0.1 with losses 0.02 and 0.5 loses (0.02 + 0.5)/2 = 0.26; a
    /// chain that never leaves the bad state (bg = 0) loses 0.5; one that never moves stays in
    /// the good state it starts in and loses 0.02.
    #[test]
    fn the_mean_loss_is_the_chains_stationary_mix() {
        let ge = |gb: f64, bg: f64| {
            LossModel::GilbertElliott { p_good_to_bad: gb, p_bad_to_good: bg, loss_good: 0.02, loss_bad: 0.5 }
                .mean_loss()
        };
        assert!((ge(0.1, 0.1) - 0.26).abs() < 1e-15, "{}", ge(0.1, 0.1));
        assert!((ge(0.1, 0.0) - 0.5).abs() < 1e-15, "{}", ge(0.1, 0.0));
        assert_eq!(ge(0.0, 0.0), 0.02);
        assert_eq!(LossModel::Bernoulli { p: 0.3 }.mean_loss(), 0.3);
    }

    #[test]
    fn gilbert_elliott_mean_loss_and_bursts() {
        // 10 % mean loss in bursts of mean length 5 frames
        let ge =
            LossModel::GilbertElliott { p_good_to_bad: 0.2 / 9.0, p_bad_to_good: 0.2, loss_good: 0.0, loss_bad: 1.0 };
        assert!((ge.mean_loss() - 0.1).abs() < 1e-12);
        let mut l = link(ge, 0);
        let n = 200_000u32;
        for s in 0..n {
            l.send(Nanos::from_millis(5 * s as i64), s, s);
            while l.receive(Nanos::from_millis(5 * s as i64)).is_some() {}
        }
        while l.receive(Nanos(i64::MAX)).is_some() {}
        let st = *l.stats();
        let loss = st.lost_on_link as f64 / n as f64;
        assert!((loss - 0.1).abs() < 0.01, "loss {loss}");
        assert_eq!(st.received + st.lost_on_link, n as u64);
        // every loss shows up as a gap in the sequence, except losses after the last delivery
        assert!(st.missing_frames <= st.lost_on_link && st.missing_frames + 200 > st.lost_on_link);
        assert!(st.longest_missing_run >= 20, "bursty loss makes long runs: {}", st.longest_missing_run);
    }

    /// With jitter, a packet arrives after latency + U(0, jitter): one packet at a time (so
    /// none is stale), polled every 0.1 ms, each is delivered no sooner than 20 ms and no later
    /// than 20 + 5 ms after it was sent, and the delays spread over most of that range.
    #[test]
    fn jitter_delays_each_packet_by_the_latency_plus_up_to_the_jitter() {
        let mut l = link(LossModel::NONE, 5);
        let (mut lo, mut hi) = (i64::MAX, i64::MIN);
        for s in 0..200u32 {
            let sent = Nanos::from_millis(100 * s as i64);
            l.send(sent, s, s);
            let delay = (0..300)
                .map(|k| sent + Nanos::from_micros(100 * k))
                .find(|t| l.receive(*t) == Some(s))
                .map(|t| (t - sent).0);
            let delay = delay.unwrap_or_else(|| panic!("packet {s} not delivered within 30 ms"));
            (lo, hi) = (lo.min(delay), hi.max(delay));
        }
        assert!(lo >= Nanos::from_millis(20).0 && hi <= Nanos::from_millis(25).0, "delays {lo}..{hi} ns");
        assert!(hi - lo > Nanos::from_millis(4).0, "delays {lo}..{hi} ns: the jitter should spread them");
    }

    #[test]
    fn jitter_reorders_and_stale_packets_are_dropped() {
        let mut l = link(LossModel::NONE, 30);
        for s in 0..1000u32 {
            l.send(Nanos::from_millis(5 * s as i64), s, s);
        }
        let mut last = None;
        while let Some(s) = l.receive(Nanos(i64::MAX)) {
            assert!(last.is_none_or(|p| s > p));
            last = Some(s);
        }
        assert!(l.stats().stale > 0);
        assert_eq!(l.stats().stale + l.stats().received, 1000);
    }
}
