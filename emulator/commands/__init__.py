"""The command port: the line editor, the command parser, the dispatcher and every command."""
