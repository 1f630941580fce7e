//! The searches of a plan driven from the database: each one's evaluations read back from the
//! EDMD jobs (done, failed for good, queued or running), and its next step.
//!
//! Nothing is kept between calls: the jobs are the searches' state. A call reads every EDMD job
//! once and hands each to the searches of its state point (O(jobs × knobs searched) hashes, then
//! O(the state point's jobs) per search), which a driver does when jobs have finished. The
//! searches of one table that share a [`TuneSearch::pool`] decide together ([`crate::pool`]):
//! O(searches²) key comparisons and O(pool² × its runs) per call (three times that where a
//! follower that differs from the leader in both keys asks its two scouts where they stand), a
//! few hundred at most.

use std::collections::{BTreeSet, HashMap};

use edmd::Scene;
use jobs::{JobSpec, TuneGoal, TuneSearch};
use report::{Clock, EdmdRow};
use store::Store;

use crate::{
    Evaluation, Goal, Outcome, Proposal, Range, Step, TuneError, loosest_safe, minimise, pool,
};

#[derive(Debug, thiserror::Error)]
pub enum DriveError {
    #[error(transparent)]
    Results(#[from] results::Error),
    #[error("search of {knob} in [{lo}, {hi}]: {source}")]
    Settings {
        knob: String,
        lo: f64,
        hi: f64,
        source: TuneError,
    },
}

/// One search and where it stands.
#[derive(Clone, Debug)]
pub struct SearchStep {
    pub search: TuneSearch,
    pub step: Step,
    /// Its evaluations done in its range (failed ones included), for reports.
    pub done: Vec<Evaluation>,
}

impl SearchStep {
    /// The jobs to submit for this step (none unless it proposes).
    pub fn jobs(&self) -> Vec<JobSpec> {
        match &self.step {
            Step::Propose(proposals) => proposals
                .iter()
                .map(|p| self.search.evaluation(p.x, p.repeat))
                .collect(),
            _ => Vec::new(),
        }
    }
}

/// The range and goal of a search as the pure search takes them.
pub fn goal_of(search: &TuneSearch) -> Result<(Range, Goal), DriveError> {
    let settings_error = |source| DriveError::Settings {
        knob: search.knob.clone(),
        lo: search.range[0],
        hi: search.range[1],
        source,
    };
    let range = Range::new(search.range[0], search.range[1]).map_err(settings_error)?;
    let max_evaluations = search.max_evaluations as usize;
    let goal = match search.goal {
        TuneGoal::Min(_) => Goal::Minimise(minimise::Settings {
            max_evaluations,
            ..Default::default()
        }),
        // Every knob a search may loosen is looser when larger (ε_d, nr_tol, ε_nnl).
        TuneGoal::LoosestSafe => Goal::LoosestSafe(loosest_safe::Settings {
            max_evaluations,
            ..Default::default()
        }),
    };
    Ok((range, goal))
}

/// The record field that holds τ_c by `clock`: what a search minimising that τ_c names.
pub fn tau_c_field(clock: Clock) -> &'static str {
    match clock {
        Clock::Cpu => "tau_c_cpu_us",
        Clock::Wall => "tau_c_us",
    }
}

/// Where every search stands, from the jobs in the store.
pub async fn steps(store: &Store, searches: &[TuneSearch]) -> Result<Vec<SearchStep>, DriveError> {
    if searches.is_empty() {
        return Ok(Vec::new());
    }
    let needs = |clock_field: &str| {
        searches
            .iter()
            .any(|s| matches!(&s.goal, TuneGoal::Min(f) if f == clock_field))
    };
    // τ_c by the clock the goal names; every other field is the same by either clock.
    let wall = results::edmd_scenes(store, Clock::Wall).await?;
    let cpu = if needs(tau_c_field(Clock::Cpu)) {
        results::edmd_scenes(store, Clock::Cpu).await?
    } else {
        Vec::new()
    };
    let (failed, pending) = results::edmd_unfinished_scenes(store).await?;
    let by_point = StatePoints::new(searches);
    let (wall, cpu) = (
        by_point.sort(&wall, |r| &r.0),
        by_point.sort(&cpu, |r| &r.0),
    );
    let (failed, pending) = (
        by_point.sort(&failed, |s| s),
        by_point.sort(&pending, |s| s),
    );
    let evaluated: Vec<(Vec<Evaluation>, Vec<Proposal>)> = searches
        .iter()
        .enumerate()
        .map(|(i, search)| {
            let runs = match &search.goal {
                TuneGoal::Min(f) if f == tau_c_field(Clock::Cpu) => &cpu[i],
                _ => &wall[i],
            };
            evaluations(search, runs, &failed[i], &pending[i])
        })
        .collect();
    // The searches of one table that pool their evaluations, in the plan's order (the middle
    // one leads).
    let keys: Vec<String> = searches.iter().map(TuneSearch::pool).collect();
    // A search listed twice (by two campaigns of one plan) is one member, its first listing.
    let first: Vec<usize> = searches
        .iter()
        .map(|s| searches.iter().position(|t| t == s).unwrap_or(0))
        .collect();
    searches
        .iter()
        .enumerate()
        .map(|(i, search)| {
            let (range, goal) = goal_of(search)?;
            let pool: Vec<usize> = (0..searches.len())
                .filter(|&j| keys[j] == keys[i] && first[j] == j)
                .collect();
            let members: Vec<pool::Member> = pool
                .iter()
                .map(|&j| pool::Member {
                    done: &evaluated[j].0,
                    in_flight: &evaluated[j].1,
                    coordinates: [searches[j].template.phi, searches[j].template.x0],
                })
                .collect();
            let me = pool.iter().position(|&j| j == first[i]).unwrap_or(0);
            let step = crate::next_in_pool(&range, &goal, &members, me);
            // Runs of the same scenes outside the range (another search's, a grid's) are not
            // this search's.
            let mut done = evaluated[i].0.clone();
            done.retain(|e| range.contains(e.x));
            Ok(SearchStep {
                step,
                search: search.clone(),
                done,
            })
        })
        .collect()
}

/// The searches by state point, to hand each the jobs of its own state point: O(jobs × knobs)
/// hashes instead of every search looking at every job.
struct StatePoints<'a> {
    knobs: BTreeSet<&'a str>,
    searches: HashMap<(&'a str, String), Vec<usize>>,
    count: usize,
}

impl<'a> StatePoints<'a> {
    fn new(searches: &'a [TuneSearch]) -> Self {
        let mut by_point: HashMap<(&str, String), Vec<usize>> = HashMap::new();
        for (i, s) in searches.iter().enumerate() {
            by_point
                .entry((s.knob.as_str(), s.state_point()))
                .or_default()
                .push(i);
        }
        StatePoints {
            knobs: searches.iter().map(|s| s.knob.as_str()).collect(),
            searches: by_point,
            count: searches.len(),
        }
    }

    /// `items` handed to the searches whose state point each one's scene is (candidates:
    /// [`TuneSearch::evaluates`] decides).
    fn sort<'i, T>(&self, items: &'i [T], scene: impl Fn(&T) -> &Scene) -> Vec<Vec<&'i T>> {
        let mut sorted = vec![Vec::new(); self.count];
        for item in items {
            for &knob in &self.knobs {
                let key = (knob, jobs::state_point_of(scene(item), knob));
                for &i in self.searches.get(&key).into_iter().flatten() {
                    sorted[i].push(item);
                }
            }
        }
        sorted
    }
}

/// A search's evaluations done and in flight. For "loosest safe", a run is judged against the
/// run of the tightest value (repeat 0): until that one is done the others count as in flight.
fn evaluations(
    search: &TuneSearch,
    runs: &[&(Scene, EdmdRow)],
    failed: &[&Scene],
    pending: &[&Scene],
) -> (Vec<Evaluation>, Vec<Proposal>) {
    let mine = |scene: &&Scene| search.evaluates(scene);
    let mut in_flight: Vec<Proposal> = pending
        .iter()
        .filter_map(mine)
        .map(|(x, repeat)| Proposal { x, repeat })
        .collect();
    let mut done: Vec<Evaluation> = failed
        .iter()
        .filter_map(mine)
        .map(|(x, repeat)| Evaluation {
            x,
            repeat,
            outcome: Outcome::Failed,
        })
        .collect();
    let is_reference = |scene: &&Scene| mine(scene) == Some((search.range[0], 0));
    let reference = runs
        .iter()
        .find(|(scene, _)| is_reference(&scene))
        .map(|(_, row)| row);
    // Without a reference that will ever be done, a run cannot be judged: left out.
    let reference_failed = failed.iter().any(is_reference);
    for (scene, row) in runs.iter().copied() {
        let Some((x, repeat)) = mine(&scene) else {
            continue;
        };
        let outcome = match (&search.goal, reference) {
            (TuneGoal::Min(field), _) => Outcome::Value(match field.as_str() {
                "nr_iterations_mean" => row.nr_iterations_mean,
                _ => row.tau_c_us,
            }),
            (TuneGoal::LoosestSafe, Some(reference)) => {
                Outcome::Safe(report::safe_against(row, reference))
            }
            (TuneGoal::LoosestSafe, None) => {
                if !reference_failed {
                    in_flight.push(Proposal { x, repeat });
                }
                continue;
            }
        };
        done.push(Evaluation { x, repeat, outcome });
    }
    (done, in_flight)
}
