"""``python -m hitrobot_server``."""

if __name__ == "__main__":  # not when a worker process (spawn) imports this as __mp_main__
    from .cli import main

    raise SystemExit(main())
