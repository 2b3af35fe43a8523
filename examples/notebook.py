# %% [markdown]
# # drumroll in a notebook
#
# A notebook as a `# %%` script: open it in JupyterLab or VS Code as a notebook (Jupytext
# reads the cells), or run it as it is, `python examples/notebook.py`, which writes the
# estimate's report into `notebook-output/` (or the folder `DRUMROLL_NOTEBOOK_OUT` names).
# Every object below shows itself in a notebook: its headline, its main table and its key
# figure; progress bars show while the work runs.

# %%
import os
from pathlib import Path

import drumroll
from drumroll.reporting.outputs import write_outputs

try:  # in a notebook, `display` shows an object as a notebook does
    from IPython.display import display
except ImportError:  # run as a plain script: say what each object is
    def display(obj: object) -> None:
        print(repr(obj))

HERE = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
DATA = HERE.parent / "data"
OUT = Path(os.environ.get("DRUMROLL_NOTEBOOK_OUT", "notebook-output"))

# %% [markdown]
# ## The onsets of a recording
#
# The bundled recording of the paper's Table 2 set-up (d = 131 mm, h = 80 mm), simulated
# with known truth: α = 0.90.

# %%
onsets = drumroll.detect(DATA / "table2_h80.flac")
display(onsets)

# %% [markdown]
# ## What the measured geometry predicts (the paper's "computed t_B")

# %%
predictions = drumroll.predict(DATA / "table2_h80.toml", n_draws=5000)
display(predictions)

# %% [markdown]
# ## The estimate
#
# Posteriors of α, t_B, the pivot and the height under the exact pendulum, compared with
# the small-angle pendulum and the power law. Warnings come first, then the headline.

# %%
result = drumroll.estimate(DATA / "table2_h80.flac", DATA / "table2_h80.toml")
display(result)

# %%
alpha = result.parameter("alpha")
print(f"alpha = {alpha.mean:.5f} ± {alpha.sd:.5f} (90 % HDI {alpha.hdi_low:.5f} … "
      f"{alpha.hdi_high:.5f}); preferred model: {result.preferred}")

# %% [markdown]
# Any figure of the report, as a matplotlib figure shown inline:

# %%
corner = result.figure("corner")
display(corner)

# %% [markdown]
# The report as `drumroll estimate` writes it: `report.html` (one page, figures embedded,
# opens offline and prints), `report.md`, `summary.json`, `posterior.nc` and the figures.

# %%
written = write_outputs(result, OUT, overwrite=True)
print(f"report: {written['report_html']}")

# %% [markdown]
# ## A table of several recordings
#
# The soft and the hard drumhead (the paper: α rises by 4 %), cached by content beside the
# runs file (or in `DRUMROLL_NOTEBOOK_CACHE`).

# %%
runs = drumroll.load_runs(HERE / "tension.toml")
cache = os.environ.get("DRUMROLL_NOTEBOOK_CACHE")
table = drumroll.run_table(runs, cache_dir=Path(cache) if cache else None)
display(table)
