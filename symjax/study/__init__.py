"""The study "plan on the completion, score on the truth" (issue 15): for each view and hand,
grasps planned on the true mesh (T), the completion (C) and the observed points (P), the top
grasps of each rolled out on the true object.

Modules: ``config`` (:class:`StudyConfig`), ``protocol`` (one view), ``runner``
(:func:`run_study`: batches, resumable files), ``summary`` (tables, figure, report).
"""

from symjax.study.config import PLANNING_MESHES, StudyConfig
from symjax.study.protocol import study_view
from symjax.study.runner import run_study
from symjax.study.summary import summarise, write_report

__all__ = ["PLANNING_MESHES", "StudyConfig", "run_study", "study_view", "summarise", "write_report"]
