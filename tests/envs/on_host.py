"""What an env returns, on the host: the tests compare with CPU tensors, and a GPU machine's envs
return CUDA ones."""
import torch


def on_host(result):
    """reset()'s (obs, info) or step()'s (obs, reward, terminated, truncated, info) with every
    tensor, also in info, copied to the CPU."""
    def host(x):
        if torch.is_tensor(x):
            return x.cpu()
        if isinstance(x, dict):
            return {k: host(v) for k, v in x.items()}
        return x

    return tuple(host(x) for x in result)
