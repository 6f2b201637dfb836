"""stook's validator accepts and refuses exactly what ReSim's validator does."""

from __future__ import annotations

from hypothesis import event, given, settings
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.proto import metrics_pb2 as pb
from stook.sdk import find_problems, validate_job_metrics
from tests.hypothesis_profiles import examples
from tests.strategies import job_metrics_cases, mutated_job_metrics, valid_job_metrics


def _settings(max_examples: int, *, derandomize: bool = False) -> settings:
    return settings(examples(max_examples), derandomize=derandomize)


def resim_accepts(msg: pb.JobMetrics) -> bool:
    resim_msg = resim_pb.JobMetrics.FromString(msg.SerializeToString())
    try:
        resim_validate(resim_msg)
    except Exception:  # any failure of ReSim's validator is a refusal
        return False
    return True


def describe(msg: pb.JobMetrics) -> str:
    problems = find_problems(msg)
    return "\n".join(map(str, problems)) or "(no problems)"


@_settings(250)
@given(job_metrics_cases())
def test_stook_and_resim_agree(msg: pb.JobMetrics) -> None:
    resim = resim_accepts(msg)
    stook = not find_problems(msg)
    event("valid" if resim else "invalid")
    assert stook == resim, f"ReSim accepts: {resim}; stook says:\n{describe(msg)}\n{msg}"


@_settings(60)
@given(valid_job_metrics())
def test_generated_valid_outputs_are_valid(msg: pb.JobMetrics) -> None:
    # The generator of valid outputs must really make valid ones, or the
    # agreement test above would mostly compare refusals.
    assert resim_accepts(msg), describe(msg)
    validate_job_metrics(msg)


def test_mutations_make_invalid_outputs_often() -> None:
    refused = total = 0

    # A count over random draws: derandomized, so that CI cannot flake on an unlucky seed.
    @_settings(60, derandomize=True)
    @given(mutated_job_metrics())
    def count(msg: pb.JobMetrics) -> None:
        nonlocal refused, total
        refused += not resim_accepts(msg)
        total += 1

    count()
    assert total >= 10
    assert refused >= total // 3, f"only {refused} of {total} mutated outputs were refused"
