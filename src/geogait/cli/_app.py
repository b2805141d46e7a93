"""The typer application objects every command module registers on."""

import typer

app = typer.Typer(
    name="geogait",
    help="Adaptive, data-driven gait modeling and in-situ gait optimisation of principally "
    "kinematic locomotors.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
figure_app = typer.Typer(help="Reproduce the paper's figures.", no_args_is_help=True)
app.add_typer(figure_app, name="figure")
