"""``navstack telegram``: the stack live in the simulator, commanded from a Telegram chat."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail


@app.command()
def telegram(
    allow: Annotated[list[int] | None, typer.Option(
        "--allow", help="Chat id allowed to command the robot (repeat for several; "
                        "required: there is no open default).")] = None,
    token_file: Annotated[Path | None, typer.Option(
        help="File holding the bot token (first line); default: "
             "$NAVSTACK_TELEGRAM_TOKEN.")] = None,
    api_url: Annotated[str, typer.Option(
        help="Bot API base URL (python-telegram-bot's base_url): a local Bot API server "
             "or the fake one.")] = "https://api.telegram.org/bot",
    targets: Annotated[Path | None, typer.Option(
        help="Targets YAML (name, latitude, longitude, yaw[, x, y]); default: the world's "
             "named waypoints.")] = None,
    world: Annotated[str, typer.Option(help="World name or path.")] = "office",
    robot: Annotated[str, typer.Option(help="Robot profile.")] = "diff_drive",
    seed: Annotated[int, typer.Option(help="Random seed.")] = 1,
    rate: Annotated[float, typer.Option(help="Real-time factor.")] = 1.0,
    progress: Annotated[float, typer.Option(help="Seconds between progress replies.")] = 15.0,
    web: Annotated[bool, typer.Option("--web", help="Also serve the web dashboard (token "
                                      "from $NAVSTACK_DASHBOARD_TOKEN or generated).")] = False,
    port: Annotated[int, typer.Option(help="Dashboard port.")] = 8080,
    duration: Annotated[float | None, typer.Option(help="Stop after this many simulated "
                                                   "seconds (default: until Ctrl-C).")] = None,
) -> None:
    """Run the stack live and answer a Telegram bot: a location sends the robot to the
    nearest target, 1 stops it, /help lists the commands."""
    from navstack.interfaces.credentials import read_secret
    from navstack.interfaces.live_cli import LiveOptions, close_viewers, open_viewers, warm_up
    from navstack.interfaces.live_runner import LiveRunner
    from navstack.interfaces.stack import NavStack
    from navstack.interfaces.telegram import TelegramBot, TelegramParams, load_targets
    from navstack.interfaces.telegram.bot import TOKEN_ENV

    if not allow:
        raise fail("no chat is allowed: give --allow CHAT_ID (the bot refuses every other "
                   "chat and tells it its id)")
    try:
        token = read_secret("bot token", file=token_file, env=TOKEN_ENV, required=True)
        assert token is not None
        params = TelegramParams.from_mapping(
            {"allowed_chats": allow, "api_url": api_url, "progress_period": progress},
            key_path="telegram")
        stack = NavStack(world, robot, seed=seed)
        warm_up(stack)
        runner = LiveRunner(stack, real_time_factor=rate)
        handles = open_viewers(runner, LiveOptions(web=web, port=port,
                                                   real_time_factor=rate))
    except NavstackError as exc:
        raise fail(str(exc)) from None
    bot = None
    try:
        runner.start()
        from navstack.interfaces.geo_frame import GeoFrame

        chosen = None
        if targets is not None:
            geo = runner.call(GeoFrame.for_stack)
            chosen = load_targets(targets, geo)
        bot = TelegramBot(runner, token, params, chosen)
        bot.start()
        typer.echo(f"telegram bot running: {len(params.allowed_chats)} allowed chat(s), "
                   f"targets: {', '.join(t.name for t in bot.targets)}")
        end = None if duration is None else runner.now + duration
        while runner.running and (end is None or runner.now < end):
            runner.wait(0.2)
    except KeyboardInterrupt:
        pass
    except NavstackError as exc:
        raise fail(str(exc)) from None
    finally:
        if bot is not None:
            bot.stop()
        close_viewers(handles)
        runner.stop()
    typer.echo(f"stopped at {runner.now:.1f} s simulated")
