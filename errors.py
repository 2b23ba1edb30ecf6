"""The one exception type that user-facing commands turn into a one-line message and exit code 2."""


class InputError(ValueError):
    """Bad user input (a parameter, an equation, a file, a command-line value).

    The message is a single line that names the offending object and attribute, e.g.
    ``motor_neuron: parameter 'tau_motor' must be positive, got -9. ms``.
    """
