"""The installed import names: ``viscore.metrics`` and friends, never bare ``metrics``."""

import subprocess
import sys


def test_user_modules_named_metrics_and_cli_do_not_shadow_ours(tmp_path):
    (tmp_path / "metrics.py").write_text("raise ImportError('user metrics.py was imported')\n")
    (tmp_path / "cli.py").write_text("raise ImportError('user cli.py was imported')\n")
    (tmp_path / "generators").mkdir()
    (tmp_path / "generators" / "__init__.py").write_text("MINE = True\n")
    code = ("from viscore.metrics import assert_conservative\n"
            "from viscore.generators import REGISTRY\n"
            "from viscore.cli.main import main\n"
            "import generators\n"
            "assert generators.MINE\n"
            "print(sorted(REGISTRY)[0], assert_conservative.__module__)\n")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [sorted(__import__("viscore.generators").generators.REGISTRY)[0],
                                   "viscore.metrics.conservativeness"]
