"""Process and command-line plumbing every program shares: the package version, raw ptys, children that die
with their parent, optional extras, the options and exit statuses of every command.
"""
