SCENARIOS = ("static",)


class CrowdNavEnv:
    pass


class CrowdNavReward:
    pass
