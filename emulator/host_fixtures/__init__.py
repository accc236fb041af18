"""What a host library's own tests use: buildhat-emulator as a child process, its pytest fixtures and
gpiozero pin factory.
"""
