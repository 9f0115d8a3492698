"""`cocobench view`: a browser viewer of run folders that shows how a team coordinated.

`source` reads run folders live (only the bytes appended since the last look), `timeline`
and `signals` turn a trajectory into what the episode page shows (reusing the benchmark's
step classification and construct formulas), `pages` renders the Jinja templates, `server`
serves them on 127.0.0.1 and `export` writes them as a static folder.
"""
