//! The sensor streams of a live ROS 2 graph, as `terraslip node` reads
//! them: with a topics file, the topics it names (or the only one of a
//! type) from the first message; without one, every candidate topic is
//! held over the warm-up window, `import` decides from the held messages
//! as it decides from a recording (the topic of each stream, the tread
//! speeds' scale, an IMU's mounting, whether a heading agrees with the GNSS
//! course), and the held messages are then read with what it settled, so
//! that no row is lost.

use std::path::PathBuf;

use terraslip_io::PoseMount;
use terraslip_ros2::import::revisit::{Revision, Revisit};
use terraslip_ros2::import::{LiveChoice, LiveImport, LiveRow, Settled};
use terraslip_ros2::{Ros2Error, Topic, TopicsConfig};

enum State {
    /// Holding every candidate until the window is full.
    Choosing(Box<LiveChoice>),
    Reading(Box<LiveImport>),
}

/// A live graph's streams, turned into drive-log rows.
pub struct LiveStreams {
    label: PathBuf,
    topics: Vec<Topic>,
    cfg: TopicsConfig,
    /// Stamp time held before deciding, s.
    window: f64,
    state: State,
    /// What the window settled, until [`Self::take_settled`].
    settled: Option<Settled>,
    /// Held messages that made no row when read after the choice.
    bad: Vec<String>,
    /// The topics file the choice settled, until the decisions it made
    /// from the data are watched (once the rows' origin is known).
    to_watch: Option<TopicsConfig>,
    /// The decisions made from the data, checked over later windows.
    revisit: Option<Revisit>,
}

impl LiveStreams {
    /// The streams of `topics` (the graph as discovered, named `label` in
    /// errors). With `choose`, the topics are chosen from the first
    /// `window` s of stamp time; else at once from `cfg` (the topics file).
    pub fn new(
        label: impl Into<PathBuf>,
        topics: Vec<Topic>,
        cfg: &TopicsConfig,
        choose: bool,
        window: f64,
    ) -> Result<Self, Ros2Error> {
        let label = label.into();
        let state = if choose {
            State::Choosing(Box::new(LiveChoice::new(
                label.clone(),
                topics.clone(),
                cfg,
            )?))
        } else {
            State::Reading(Box::new(LiveImport::new(
                label.clone(),
                topics.clone(),
                cfg,
            )?))
        };
        Ok(Self {
            label,
            topics,
            cfg: cfg.clone(),
            window,
            state,
            settled: None,
            bad: Vec::new(),
            to_watch: None,
            revisit: None,
        })
    }

    /// The topics to read (indices into the topics given to
    /// [`Self::new`]), with the streams each feeds (`candidate` while the
    /// choice is open).
    pub fn subscriptions(&self) -> Vec<(usize, Vec<&'static str>)> {
        match &self.state {
            State::Choosing(c) => c
                .candidates()
                .iter()
                .map(|&i| (i, vec!["candidate"]))
                .collect(),
            State::Reading(r) => r
                .subscriptions()
                .into_iter()
                .filter_map(|(t, roles)| Some((self.topics.iter().position(|x| x == t)?, roles)))
                .collect(),
        }
    }

    /// The rows message `data` (CDR) of topic `topic` (an index into the
    /// topics given to [`Self::new`]) makes; none while the choice is open
    /// (the message is held). `recv_ns`: its arrival, ns since the epoch.
    pub fn message(
        &mut self,
        topic: usize,
        recv_ns: u64,
        data: &[u8],
    ) -> Result<Vec<LiveRow>, Ros2Error> {
        let (rows, origin) = match &mut self.state {
            State::Choosing(c) => return c.hold(topic, recv_ns, data).map(|_| Vec::new()),
            State::Reading(r) => (r.message(topic, recv_ns, data)?, r.origin_ns()),
        };
        Ok(self.revisited(origin, rows))
    }

    /// `rows` as the estimator is to see them: through the watch on the
    /// decisions made from the data (the same [`Revisit`] `estimate`
    /// passes a recording through), once the rows' origin (`origin`, ns
    /// since the epoch) is known.
    fn revisited(&mut self, origin: Option<u64>, rows: Vec<LiveRow>) -> Vec<LiveRow> {
        if self.revisit.is_none() {
            if let (Some(origin), Some(settled)) = (origin, &self.to_watch) {
                self.revisit = Revisit::new(&self.cfg, settled, origin);
                self.to_watch = None;
            }
        }
        match &mut self.revisit {
            Some(r) => rows.into_iter().filter_map(|row| r.row(row)).collect(),
            None => rows,
        }
    }

    /// The decisions made again since the last call (each with its
    /// `decided:` line).
    pub fn take_revisions(&mut self) -> Vec<Revision> {
        self.revisit
            .as_mut()
            .map(Revisit::take_new)
            .unwrap_or_default()
    }

    /// Every decision made again so far, one line each.
    pub fn revisions(&self) -> Vec<String> {
        self.revisit.as_ref().map_or_else(Vec::new, |r| {
            r.revisions().iter().map(|r| r.line.clone()).collect()
        })
    }

    /// Whether the window is full and the choice is to be made.
    pub fn due(&self) -> bool {
        matches!(&self.state, State::Choosing(c) if c.span() >= self.window)
    }

    /// Whether the choice is still open.
    pub fn choosing(&self) -> bool {
        matches!(self.state, State::Choosing(_))
    }

    /// Decides from the messages held (with `import`'s code) and returns
    /// the rows they make, read with what was settled; nothing when the
    /// choice was made already or nothing is held. The held messages that
    /// cannot make a row are kept for [`Self::take_bad`].
    pub fn decide(&mut self) -> Result<Vec<LiveRow>, Ros2Error> {
        let State::Choosing(c) = &mut self.state else {
            return Ok(Vec::new());
        };
        if c.held() == 0 {
            return Ok(Vec::new());
        }
        let settled = c.decide(&self.cfg)?;
        let mut reader = LiveImport::new(self.label.clone(), self.topics.clone(), &settled.topics)?;
        let held = c.take_held();
        self.to_watch = Some(settled.topics.clone());
        let mut rows = Vec::new();
        for (topic, recv_ns, data) in held {
            match reader.message(topic, recv_ns, &data) {
                Ok(r) => rows.extend(self.revisited(reader.origin_ns(), r)),
                Err(e) => self.bad.push(e.to_string()),
            }
        }
        self.state = State::Reading(Box::new(reader));
        self.settled = Some(settled);
        Ok(rows)
    }

    /// What the window settled, once (after [`Self::decide`]).
    pub fn take_settled(&mut self) -> Option<Settled> {
        self.settled.take()
    }

    /// Held messages that made no row when read after the choice (each
    /// with the reason), once.
    pub fn take_bad(&mut self) -> Vec<String> {
        std::mem::take(&mut self.bad)
    }

    /// Where the pose reference sits on the robot, as `import` reads it
    /// (the topics file's `[pose] lever_arm`, else the static transforms
    /// received so far), with the `decided:` line the first time it is
    /// known; nothing while the choice is open.
    pub fn lever_arm(&mut self) -> (Option<PoseMount>, Option<String>) {
        match &mut self.state {
            State::Choosing(_) => (None, None),
            State::Reading(r) => r.lever_arm(),
        }
    }

    /// Time 0 of the rows, ns since the epoch (once rows are made).
    pub fn origin_ns(&self) -> Option<u64> {
        match &self.state {
            State::Choosing(_) => None,
            State::Reading(r) => r.origin_ns(),
        }
    }
}

/// The track width the model starts from, as `estimate` starts: `given`
/// (`--track-width`), else the topics file's `[meta] track_width`, else the
/// separation the tread speeds are made with (the controller's own scale),
/// else `default`; `topics` is the topics file the streams are read with
/// (for a choice made live, the one it settled).
pub fn start_width(given: Option<f64>, topics: &TopicsConfig, default: f64) -> f64 {
    given
        .or(topics.meta.track_width)
        .or(topics
            .wheels
            .separation
            .filter(|s| s.is_finite() && *s > 0.0))
        .unwrap_or(default)
}
