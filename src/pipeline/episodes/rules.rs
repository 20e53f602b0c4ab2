//! The rules an episodes job's options obey among themselves, the same for `minos episodes`
//! and Python's `sample_episodes`: both front doors check them before anything is read
//! ([`check_options`]), and [`run_job`](super::run_job) checks them again for callers of
//! the library.

use super::SampleConfig;
use crate::episode::vln::export::{EpisodeExport, VlnFormat};
use crate::episode::Task;
use crate::vocab::Vocabulary;

/// Options of an episodes job that break a rule. Messages are one line and name no
/// front-door flag or keyword (the front doors add theirs).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum EpisodeOptionsError {
    /// The distance bins' thresholds (easy/medium, medium/hard) are not in increasing order.
    #[error("expected two increasing distances")]
    BinsOutOfOrder {
        /// The thresholds given, in metres.
        bins: [f32; 2],
    },
    /// A VLN export was asked of episodes of another task.
    #[error("VLN exports need task `vln`, not `{}`", task.name())]
    VlnExportOfOtherTask {
        /// The export asked for.
        format: VlnFormat,
        /// The task sampled.
        task: Task,
    },
    /// Habitat's layout was asked of VLN episodes, which it cannot hold.
    #[error(
        "VLN episodes export as `{}` (habitat-lab's R2RVLN-v1) or `{}`",
        EpisodeExport::Vln(VlnFormat::VlnCe).term_name(),
        EpisodeExport::Vln(VlnFormat::R2r).term_name()
    )]
    HabitatExportOfVln,
    /// More than one instance per category was asked of a task without categories.
    #[error(
        "at least {min_instances} instances per category: only task `{}` has categories, not `{}`",
        Task::ObjectGoal.name(),
        task.name()
    )]
    MinInstancesOfOtherTask {
        /// The instances asked for.
        min_instances: u32,
        /// The task sampled.
        task: Task,
    },
}

/// Checks a job's options against each other: the sampling's distance bins in increasing
/// order, more than one instance per category only for ObjectGoal, and each of `exports` one
/// that episodes of the sampling's task can be written in (VLN formats for VLN episodes only,
/// and VLN episodes never in Habitat's layout).
pub fn check_options(
    sample: &SampleConfig,
    exports: impl IntoIterator<Item = EpisodeExport>,
) -> Result<(), EpisodeOptionsError> {
    let (task, bins) = (sample.task, sample.bins);
    if bins[0] > bins[1] {
        return Err(EpisodeOptionsError::BinsOutOfOrder { bins });
    }
    for export in exports {
        match export {
            EpisodeExport::Vln(format) if task != Task::Vln => {
                return Err(EpisodeOptionsError::VlnExportOfOtherTask { format, task })
            }
            EpisodeExport::Habitat if task == Task::Vln => {
                return Err(EpisodeOptionsError::HabitatExportOfVln)
            }
            _ => {}
        }
    }
    if sample.min_instances > 1 && task != Task::ObjectGoal {
        return Err(EpisodeOptionsError::MinInstancesOfOtherTask {
            min_instances: sample.min_instances,
            task,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const VLNCE: EpisodeExport = EpisodeExport::Vln(VlnFormat::VlnCe);

    fn cfg(task: Task, bins: [f32; 2]) -> SampleConfig {
        SampleConfig {
            task,
            bins,
            ..SampleConfig::default()
        }
    }

    #[test]
    fn bins_must_increase() {
        assert_eq!(
            check_options(&cfg(Task::PointGoal, [3.0, 6.0]), None),
            Ok(())
        );
        assert_eq!(
            check_options(&cfg(Task::PointGoal, [4.0, 4.0]), None),
            Ok(())
        );
        let e = check_options(&cfg(Task::PointGoal, [6.0, 3.0]), None).unwrap_err();
        assert_eq!(e, EpisodeOptionsError::BinsOutOfOrder { bins: [6.0, 3.0] });
        assert_eq!(e.to_string(), "expected two increasing distances");
    }

    #[test]
    fn each_task_exports_only_in_its_formats() {
        assert_eq!(
            check_options(&cfg(Task::Vln, [3.0, 6.0]), Some(VLNCE)),
            Ok(())
        );
        let r2r = EpisodeExport::Vln(VlnFormat::R2r);
        assert_eq!(check_options(&cfg(Task::Vln, [3.0, 6.0]), [r2r]), Ok(()));
        for task in [Task::PointGoal, Task::ObjectGoal, Task::RoomGoal] {
            let hab = EpisodeExport::Habitat;
            assert_eq!(check_options(&cfg(task, [3.0, 6.0]), [hab]), Ok(()));
            let e = check_options(&cfg(task, [3.0, 6.0]), [hab, r2r]).unwrap_err();
            assert_eq!(
                e,
                EpisodeOptionsError::VlnExportOfOtherTask {
                    format: VlnFormat::R2r,
                    task
                }
            );
            assert_eq!(
                e.to_string(),
                format!("VLN exports need task `vln`, not `{}`", task.name())
            );
        }
        let e = check_options(&cfg(Task::Vln, [3.0, 6.0]), [EpisodeExport::Habitat]).unwrap_err();
        assert_eq!(e, EpisodeOptionsError::HabitatExportOfVln);
        assert_eq!(
            e.to_string(),
            "VLN episodes export as `vlnce` (habitat-lab's R2RVLN-v1) or `r2r`"
        );
    }

    #[test]
    fn only_objectgoal_asks_for_more_than_one_instance() {
        let with = |task, min_instances| SampleConfig {
            min_instances,
            ..cfg(task, [3.0, 6.0])
        };
        assert_eq!(check_options(&with(Task::ObjectGoal, 2), None), Ok(()));
        assert_eq!(check_options(&with(Task::PointGoal, 1), None), Ok(()));
        let e = check_options(&with(Task::RoomGoal, 3), None).unwrap_err();
        assert_eq!(
            e,
            EpisodeOptionsError::MinInstancesOfOtherTask {
                min_instances: 3,
                task: Task::RoomGoal
            }
        );
        assert_eq!(
            e.to_string(),
            "at least 3 instances per category: only task `objectgoal` has categories, not `roomgoal`"
        );
    }
}
