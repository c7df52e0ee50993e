"""Every demo runs as a notebook: its jupytext source converted to ``.ipynb`` and executed cell by
cell by a Jupyter kernel (nbclient), as JupyterLab runs it.

What a kernel does differently from ``python3 demos/<name>.py``: the command line is the kernel's
(``-f kernel.json``), ``sys.exit`` ends a cell with ``SystemExit`` (an error, even for 0), and
``__file__`` is not defined. So every demo ends with the same last cell, ``if __name__ ==
"__main__":`` and the package's ``main_block(main)``, which in a kernel runs ``main()`` with the
defaults instead of exiting, and parses no command line there (``program_args``); no other cell
reads ``sys.argv``, exits or uses ``__file__`` (checked for every demo).

Executing every demo in a kernel costs a kernel and the demo's run each (3-15 s): the demos run
here are one of each kind of last cell, each at its smallest size (``docs/demo_results.SMALL``,
passed by a cell inserted before the last one): the FE demos' block (``cli.main_block``:
``two_bodies_api``, the API demo), the numpy-only demos' (``commandline.main_block`` with
``program_args``: ``paper_figures``) and ``elastic_smoke``'s (the same, with DOLFINx). The other
demos' cells are the modules the suite imports (``test_demos_run.py``, ``test_records.py``: the
same code, outside a kernel) and their ``main`` runs as a program at the same size
(``test_demos_run.py``, 1 and 2 ranks).
"""

import json

import pytest

from tests.demos.test_demos_run import shown
from tests.helpers import ROOT, singleton_env

pytestmark = pytest.mark.serial  # each notebook runs in its own kernel, a process of its own

DEMOS = sorted(f.stem for f in (ROOT / "demos").glob("*.py") if f.stem != "__init__")
LAST_CELLS = {
    'if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults\n'
    "    cli.main_block(main)",
    'if __name__ == "__main__":  # a program: its exit code; a notebook: main() with the defaults\n'
    "    main_block(main)",
    'if __name__ == "__main__":  # in a notebook: main() with the defaults\n    main_block(main)',
}
EXECUTED = ("elastic_smoke", "paper_figures", "two_bodies_api")


def kernel_manager(where):
    """A Jupyter kernel manager whose kernel is this Python (the suite's environment: the
    installed package), not the system's ``python3`` kernel spec."""
    import sys

    from jupyter_client.kernelspec import KernelSpecManager
    from jupyter_client.manager import AsyncKernelManager

    spec = where / "kernels" / "suite"
    spec.mkdir(parents=True)
    argv = [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"]
    (spec / "kernel.json").write_text(json.dumps({"argv": argv, "language": "python"}))
    specs = KernelSpecManager(kernel_dirs=[str(spec.parent)])
    return AsyncKernelManager(kernel_name="suite", kernel_spec_manager=specs)


def notebook(name):
    import jupytext

    return jupytext.read(ROOT / "demos" / f"{name}.py")


@pytest.mark.filterwarnings("ignore:Jupyter is migrating its paths:DeprecationWarning")
@pytest.mark.parametrize("name", DEMOS)
def test_every_demo_ends_with_the_notebook_safe_block(name):
    code = [c.source for c in notebook(name).cells if c.cell_type == "code"]
    assert code[-1].strip() in LAST_CELLS, code[-1]
    for src in code[:-1]:
        for bad in ("sys.exit", "sys.argv", "__file__", "__main__", "main_block("):
            assert bad not in src, (name, bad, src[:200])


@pytest.mark.filterwarnings("ignore:Jupyter is migrating its paths:DeprecationWarning")
@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", EXECUTED)
def test_the_demo_runs_as_a_notebook(name, tmp_path):
    import nbformat
    from nbclient import NotebookClient

    from docs.demo_results import SMALL

    nb = notebook(name)
    out = tmp_path / "out"
    argv = [*SMALL[name], "--out", str(out)]
    small = f"import functools\n\nmain = functools.partial(main, {json.dumps(argv)})"
    nb.cells.insert(len(nb.cells) - 1, nbformat.v4.new_code_cell(small))
    client = NotebookClient(
        nb,
        km=kernel_manager(tmp_path),
        timeout=240,
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute(env=singleton_env())  # raises CellExecutionError naming the cell that failed
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o["output_type"] == "error"]
    text = "".join(o.get("text", "") for o in outputs if o["output_type"] == "stream")
    assert "SystemExit" not in text and "Traceback" not in text, text
    assert len(shown(text)) <= 30, text  # a demo's output stays short
    assert any(out.iterdir()), "the demo wrote nothing into --out"
