"""Error hierarchy. Only ``mechkin.cli`` catches these and maps them to exit codes."""

from __future__ import annotations

#: Exit codes of every command (the errors' ``exit_code``, a report's result; shown by
#: ``mechkin --help``, the README and the JUnit output of ``mechkin run``).
EXIT_OK, EXIT_SOLVER, EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_OUTPUT, EXIT_EXPECT = 0, 1, 2, 3, 4, 5
EXIT_CODES = {
    EXIT_OK: "ok: every solve reached its goal and every expect: held",
    EXIT_SOLVER: "a solver did not reach a target (outputs written, status says which), or "
                 "the run was cut short (--max-time, a Dask worker lost mid-job)",
    EXIT_BAD_INPUT: "bad input or an unusable output folder (nothing written)",
    EXIT_INTERNAL: "internal error (a bug: please report it)",
    EXIT_OUTPUT: "an output file could not be written (previous outputs intact)",
    EXIT_EXPECT: "an expect: entry did not hold (outputs written, summary says which)",
    130: "interrupted (SIGINT)",
    143: "terminated (SIGTERM)",
}


def exit_codes_text() -> str:
    """The exit codes, one per line (``mechkin --help``)."""
    return "\n".join(f"{c}  {what}" for c, what in EXIT_CODES.items())


#: Longest problem line kept (messages cut the strings they echo; this is the backstop).
MAX_LINE = 400


def _clip(line: str) -> str:
    return line if len(line) <= MAX_LINE else line[: MAX_LINE - 3] + "..."


class MechkinError(Exception):
    """Root of every error mechkin raises on purpose."""

    exit_code = 2


class ConfigError(MechkinError):
    """Bad input: one or more problems in mechanism or scenario files.

    ``problems`` holds one line per problem, each ``file:line: key.path: message``.
    """

    exit_code = 2

    def __init__(self, problems: list[str] | str) -> None:
        if isinstance(problems, str):
            problems = [problems]
        # one line per problem, never a flood: a line is cut at MAX_LINE characters
        self.problems = [_clip(ln) for p in problems for ln in (str(p).splitlines() or [""])]
        super().__init__("\n".join(self.problems))


class ModelError(MechkinError):
    """A mechanism that cannot be built (topology, cuts, independent joints)."""

    exit_code = 2


class SingularityError(MechkinError):
    """A singular configuration where the caller demanded a regular one."""

    exit_code = 1


class ConvergenceError(MechkinError):
    """A solver that did not converge where the caller demanded convergence."""

    exit_code = 1


class OutputError(MechkinError):
    """An output file could not be written while the run wrote it (disk full, a file system
    error): exit 4; the previous contents of the output folder stay intact."""

    exit_code = 4


class OutputDirError(OutputError):
    """An unusable output folder, found before any work (a file, not writable, a name too
    long, held by another run or by another scenario's results): bad input, exit 2."""

    exit_code = 2


class Interrupted(MechkinError):
    """SIGINT or SIGTERM: the run stopped, staging removed, previous outputs intact."""

    exit_code = 130


class ClusterError(MechkinError):
    """A Dask scheduler that does not answer, has no workers, or whose workers cannot run
    mechkin (not installed, another version): found before any job runs, exit 2."""

    exit_code = 2


class ClusterLostError(MechkinError):
    """The Dask cluster stopped answering while jobs ran (a stopped, hung or unreachable
    worker or scheduler): the run stops with nothing written, previous outputs intact, exit 1
    (the job was cut short, as by --max-time)."""

    exit_code = 1
