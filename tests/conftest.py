"""Every pytest run of a file under tests/ (each ctest entry that runs pytest is one): a run in which no test
passed fails with exit code 5, as one that collected none does. A file whose tests are all skipped (or all
deselected, or all expected failures) is not a pass. --collect-only runs are left as they are."""
import pytest

_passed = 0


def pytest_runtest_logreport(report):
    global _passed
    if report.when == "call" and report.passed:
        _passed += 1


def _tested_nothing(config, exitstatus):
    return exitstatus == pytest.ExitCode.OK and not config.option.collectonly and _passed == 0


def pytest_sessionfinish(session, exitstatus):
    if _tested_nothing(session.config, exitstatus):
        session.exitstatus = pytest.ExitCode.NO_TESTS_COLLECTED


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if _tested_nothing(config, exitstatus):
        terminalreporter.write_line("no test passed: a run that tests nothing fails (exit code 5)")
