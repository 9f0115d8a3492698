"""Human seats played in the browser: `cocobench run … --model human`.

`desk` holds the decisions the engine asks of the human seats and takes the person's
answers (`PlayDesk`, the `SeatDesk` of `models.human`); `server` serves the play page and
its API on 127.0.0.1 behind the run's random token; `prompt_parts` finds the parts of a
prompt the page shows on their own.
"""
