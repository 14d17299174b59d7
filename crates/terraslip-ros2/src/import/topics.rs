//! Which topic feeds which stream: by name, or by message type when the
//! choice is unique.

use super::evidence::Evidence;
use super::role::Role;
use crate::msg::short_type;
use crate::{Bag, Ros2Error};

/// The decisions made while choosing, and the streams the evidence could
/// not settle (each with the lines that settle it).
#[derive(Debug, Default)]
pub(super) struct Decide {
    pub evidence: Evidence,
    pub decisions: Vec<String>,
    pub ambiguous: Vec<String>,
    /// Choices taken against some evidence (the only candidate behaves as
    /// it should not).
    pub warnings: Vec<String>,
}

impl Decide {
    /// Refuses, listing every stream the evidence could not settle.
    pub fn settled(&self, bag: &Bag) -> Result<(), Ros2Error> {
        if self.ambiguous.is_empty() {
            return Ok(());
        }
        Err(Ros2Error::Bag {
            bag: bag.path.clone(),
            reason: format!(
                "the bag does not tell which topic feeds {} stream{}; name {} in a --topics file: {}",
                self.ambiguous.len(),
                if self.ambiguous.len() > 1 { "s" } else { "" },
                if self.ambiguous.len() > 1 { "each" } else { "it" },
                self.ambiguous.join("; ")
            ),
        })
    }
}

/// Picks the topic for `role`: the configured one, else the one of the most
/// preferred type class present, decided from the evidence in `d` when
/// several are (said in `d.decisions`; when the evidence cannot separate
/// them, noted in `d.ambiguous` and the first taken for now). `taken`
/// topics are not candidates.
pub(super) fn choose(
    bag: &Bag,
    role: Role,
    configured: &Option<String>,
    taken: &[usize],
    d: &mut Decide,
) -> Result<Option<usize>, Ros2Error> {
    let accepted: Vec<&str> = role
        .types()
        .iter()
        .flat_map(|c| c.iter().copied())
        .collect();
    if let Some(name) = configured {
        if name.is_empty() {
            return Ok(None);
        }
        let i = bag.topic(name).ok_or_else(|| Ros2Error::Bag {
            bag: bag.path.clone(),
            reason: format!(
                "[{}] topic `{name}` is not in the bag (it has: {})",
                role.key(),
                list(bag, &(0..bag.topics.len()).collect::<Vec<_>>())
            ),
        })?;
        let ty = short_type(&bag.topics[i].ty);
        if !accepted.contains(&ty.as_str()) {
            return Err(Ros2Error::Bag {
                bag: bag.path.clone(),
                reason: format!(
                    "[{}] topic `{name}` is {}; {} takes {}",
                    role.key(),
                    bag.topics[i].ty,
                    role.key(),
                    accepted.join(", ")
                ),
            });
        }
        return Ok(Some(i));
    }
    for class in role.types() {
        let c = candidates(bag, class, taken);
        if c.is_empty() {
            continue;
        }
        return Ok(Some(decide(bag, role, &c, d)));
    }
    Ok(None)
}

/// The topics of one type class, not `taken`.
pub(super) fn candidates(bag: &Bag, class: &[&str], taken: &[usize]) -> Vec<usize> {
    (0..bag.topics.len())
        .filter(|i| !taken.contains(i) && class.contains(&short_type(&bag.topics[*i].ty).as_str()))
        .collect()
}

/// The wheel twists (odometry, TwistStamped) of the bag, not `taken`.
pub(super) fn wheel_twists(bag: &Bag, taken: &[usize]) -> Vec<usize> {
    candidates(bag, Role::Wheels.types()[1], taken)
}

/// One of candidates `c` (not empty) for `role`, from the evidence.
pub(super) fn decide(bag: &Bag, role: Role, c: &[usize], d: &mut Decide) -> usize {
    if c.len() == 1 {
        if role == Role::Wheels {
            warn_if_filter(bag, c[0], d);
        }
        return c[0];
    }
    let key = role.key();
    let line = |i: usize| format!("`[{key}] topic = \"{}\"`", bag.topics[i].name);
    // Each candidate with the reasons against it.
    let against: Vec<(usize, Vec<String>)> = match role {
        Role::Wheels => {
            let filters: Vec<_> = c
                .iter()
                .map(|&i| (i, d.evidence.filter_signs(bag, i)))
                .collect();
            let own: Vec<usize> = filters
                .iter()
                .filter(|f| f.1.is_empty())
                .map(|f| f.0)
                .collect();
            let wheel_like: Vec<usize> = own
                .iter()
                .copied()
                .filter(|&i| d.evidence.wheel_like(bag, i))
                .collect();
            filters
                .into_iter()
                .map(|(i, mut why)| {
                    if !why.is_empty() {
                        why.insert(0, "a filter's output".into());
                    } else if own.len() > 1 && wheel_like.len() == 1 && wheel_like[0] != i {
                        why.push("its name is no drive controller's or base driver's".into());
                    }
                    (i, why)
                })
                .collect()
        }
        _ => {
            let most = c.iter().map(|&i| bag.topics[i].count).max().unwrap_or(0);
            // A filter fusing the wheels is no reference beside one that is
            // not such a filter.
            let fusion: Vec<Vec<String>> = c
                .iter()
                .map(|&i| match role {
                    Role::Pose => d.evidence.fusion_signs(bag, i),
                    _ => Vec::new(),
                })
                .collect();
            let independent = fusion.iter().any(Vec::is_empty);
            c.iter()
                .zip(fusion)
                .map(|(&i, signs)| {
                    let n = bag.topics[i].count;
                    let mut why = Vec::new();
                    if n * 10 < most {
                        why.push(format!("{n} messages against {most}: too few for a {key} stream (a goal, a single message?)"));
                    }
                    if independent && !signs.is_empty() {
                        why.push("a filter's output, fusing the robot's own sensors".into());
                        why.extend(signs);
                    }
                    (i, why)
                })
                .collect()
        }
    };
    let kept: Vec<usize> = against
        .iter()
        .filter(|a| a.1.is_empty())
        .map(|a| a.0)
        .collect();
    if kept.len() == 1 {
        let chosen = kept[0];
        let others: Vec<String> = against
            .iter()
            .filter(|a| a.0 != chosen)
            .map(|(i, why)| format!("{} ({})", bag.topics[*i].name, why.join(", ")))
            .collect();
        let runner_up = against
            .iter()
            .find(|a| a.0 != chosen)
            .map(|a| a.0)
            .unwrap_or(chosen);
        d.decisions.push(format!(
            "{key} from {} ({}), not {}; {} in a --topics file takes {}",
            bag.topics[chosen].name,
            bag.topics[chosen].ty,
            others.join(", not "),
            line(runner_up),
            bag.topics[runner_up].name
        ));
        return chosen;
    }
    let pool = if kept.is_empty() { c.to_vec() } else { kept };
    d.ambiguous.push(format!(
        "[{key}]: {} could each be it ({})",
        list(bag, &pool),
        pool.iter()
            .map(|&i| line(i))
            .collect::<Vec<_>>()
            .join(" or ")
    ));
    pool[0]
}

/// Warns when `i`, the only wheel-source candidate, is an odometry or twist
/// showing a filter's signs: its tread speeds carry the filter's fusion.
fn warn_if_filter(bag: &Bag, i: usize, d: &mut Decide) {
    let twist = candidates(bag, Role::Wheels.types()[1], &[]).contains(&i);
    let signs = d.evidence.filter_signs(bag, i);
    if twist && !signs.is_empty() {
        d.warnings.push(format!(
            "the wheels source {} looks like a filter's output ({}): its tread speeds carry the filter's corrections; it is used as the only candidate (`[wheels] topic = \"...\"` in a --topics file names the drive's own odometry or joint states if the robot publishes them)",
            bag.topics[i].name,
            signs.join(", ")
        ));
    }
}

pub(super) fn list(bag: &Bag, idx: &[usize]) -> String {
    idx.iter()
        .map(|&i| format!("{} ({})", bag.topics[i].name, bag.topics[i].ty))
        .collect::<Vec<_>>()
        .join(", ")
}
