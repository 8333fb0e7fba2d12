"""How the book is built: the model plan, the plan runner and its worker processes, the chapter executor.

:mod:`.book_models` lists every model the chapters load (behind ``motionlab train book``), :mod:`.plan` trains
such a plan in parallel worker processes (:mod:`.workers` sets them up), and :mod:`.notebook_runner` executes the
chapters (behind ``motionlab book execute``). Nothing is imported here: each module is loaded when it is used.
"""
