"""The modeling experiments give bit-identical results in-process, on 2 joblib workers and on Dask."""

import pandas as pd
import pytest

from geogait.experiments import AccuracyConfig, EnvironmentConfig, run_accuracy, run_environments

distributed = pytest.importorskip("distributed")

SWEEPS = {
    "accuracy": (run_accuracy, AccuracyConfig.quick(n_trials=8, n_cycles=5, chunk_size=1)),
    "environments": (run_environments, EnvironmentConfig.quick(n_trials=4, cycles_per_environment=6, chunk_size=1,
                                                               sensor_noise=0.3)),
}


@pytest.fixture(scope="module")
def dask_client():
    with distributed.LocalCluster(n_workers=2, processes=False, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        yield client


@pytest.mark.parametrize("name", sorted(SWEEPS))
def test_same_results_for_one_worker_two_workers_and_dask(name, dask_client):
    run, config = SWEEPS[name]
    serial = run(config, jobs=1, progress=False)
    pooled = run(config, jobs=2, progress=False)
    clustered = run(config, scheduler=dask_client, progress=False)
    assert serial.n_workers == 1 and pooled.n_workers == 2 and clustered.n_workers == 2
    assert len(serial.frame) > 0 and serial.frame.trial.nunique() == config.n_trials // (2 if name == "accuracy" else 1)
    pd.testing.assert_frame_equal(pooled.frame, serial.frame, check_exact=True)
    pd.testing.assert_frame_equal(clustered.frame, serial.frame, check_exact=True)
    assert serial.summary() == pooled.summary() == clustered.summary()
